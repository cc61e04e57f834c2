"""Online values (``observe.online``): the IL lines of a running board's latest cycle.

The oracle is the per-line trace of ``asictl sim --trace-il``: the board's latest cycle
must have exactly the rows the trace has for the same program, inputs and cycle. Two
ways: a simulation's own board asked at chosen master times (cycle for cycle against a
second, traced simulation of the same scenario), and a live board over its socket (the
monitor's path) against the CLI's trace of a scenario with the same inputs, once the
program has settled.
"""

from __future__ import annotations

import csv
import io
import os
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import assume
from hypothesis import strategies as st
from il_strategies import traceable_sources
from sized import check, sizes

from asictl.board.asi import AsiBus, Slave
from asictl.board.board import Pc2Board
from asictl.build import build, build_file, build_image
from asictl.cli import main
from asictl.codegen8051.compiler import compile_program
from asictl.errors import UserError
from asictl.host.connection import MasterAddress, open_board
from asictl.host.live.server import background_live
from asictl.host.transfer import Pc2Transport, set_start
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.il.checks import check_source
from asictl.observe.online import CycleLines, latest_cycle
from asictl.platform.master import ControlFlag
from asictl.platform.pc2 import ControlState
from asictl.runtime.line_map import LineMap, SourceLine
from asictl.sim.engine import Simulation
from asictl.sim.scenario import Scenario, load_scenario
from asictl.source import from_string

ROOT = Path(__file__).resolve().parents[2]
DEMOS = ROOT / "demos"
#: the default run's sample, and the long run's (``-m slow``)
EXAMPLES = int(os.environ.get("ASICTL_ONLINE_EXAMPLES", "20"))
LONG_EXAMPLES = int(os.environ.get("ASICTL_ONLINE_EXAMPLES", "100"))

Row = tuple[str, int, int, int, int, int | None]


def _ran(answer: dict) -> dict[SourceLine, Row]:
    return {
        SourceLine(e["file"], e["line"]): (
            e["file"], e["line"], e["rlo"], e["accu1"], e["accu2"], e["operand"]
        )
        for e in answer["lines"] if e["ran"]
    }


def _last_runs(rows: list[Row]) -> dict[SourceLine, Row]:
    """A trace cycle's rows as the view shows them: each line's last run."""
    return {SourceLine(r[0], r[1]): r for r in rows}


@pytest.mark.parametrize(("demo", "times"), [
    ("blink", [0.0, 3.0, 250.0, 499.0, 503.0, 1000.0, 1507.0]),
    ("fb", [0.0, 20.0, 55.0, 120.0, 200.0]),
    ("counter", [0.0, 30.0, 60.0, 110.0]),
])
def test_the_latest_cycle_has_the_rows_of_the_trace_at_that_cycle(demo, times):
    built = build_file(DEMOS / f"{demo}.asi")
    scenario = load_scenario(DEMOS / f"{demo}.scenario.toml")
    assert _compare_with_trace(built, scenario, times) >= len(times) - 1


def _compare_with_trace(built, scenario, times: list[float], inputs: bytes = b"") -> int:
    """Ask a simulation's board for its latest cycle at each time; each answer must be
    the trace's rows of that cycle in a second, traced run (slave n delivering
    ``inputs[n]`` in both). The cycles compared."""

    def simulation(**trace: bool) -> Simulation:
        sim = Simulation(built, scenario, duration_ms=max(times) + 50, **trace)
        for slave in sim.board.bus:
            if slave.address < len(inputs):
                slave.inputs = inputs[slave.address] & 0xF
        return sim

    traced = simulation(il_trace=True).run()
    by_time: dict[float, list[Row]] = {}
    for r in traced.il_rows:
        by_time.setdefault(round(r.time_ms, 3), []).append(
            (r.line.file, r.line.line, r.rlo, r.accu1, r.accu2, r.operand)
        )
    sim = simulation()
    sim.start()
    compared = 0
    for t in times:
        sim.run_to(t)
        offset = sim.board.now_ms - sim.now_ms()
        traps = dict(sim.runner.cpu.traps)
        answer = latest_cycle(sim.board)
        assert dict(sim.runner.cpu.traps) == traps, "the hooks are gone after the request"
        if answer["state"] != "running":
            continue
        at = round(answer["master_ms"] - offset, 3)
        assert at in by_time, (t, at)
        assert _ran(answer) == _last_runs(by_time[at]), (t, at)
        compared += 1
    return compared


@sizes(EXAMPLES, LONG_EXAMPLES)
def test_generated_programs_answer_the_rows_of_the_trace(examples: int) -> None:
    check(examples, generated_programs_answer_the_rows_of_the_trace,
          traceable_sources(), st.lists(st.integers(0, 40), min_size=1, max_size=4),
          st.binary(min_size=32, max_size=32))


def generated_programs_answer_the_rows_of_the_trace(files: dict[str, str], times, inputs) -> None:
    """Generated programs (main file and a block) with every slave projected and some of
    their inputs on: the latest cycle at each time is the trace's cycle then."""
    setup = "[SETUP]\n" + "".join(f"{a}: bbbb, 0\n" for a in range(1, 32))
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in files.items():
            (Path(tmp) / name).write_text(setup + text if name == "main.asi" else text)
        built = build_file(Path(tmp) / "main.asi")
    assume(not built.has_errors)
    compared = _compare_with_trace(built, Scenario("<generated>", None, 5.0, None, []),
                                   sorted(float(t) for t in times), inputs)
    assert compared == len(times), "the program runs at every time asked"


def test_lines_that_did_not_run_have_no_values_and_a_line_run_twice_counts():
    text = """\
[SETUP]
4: iiii, 0
17: oooo, 0
[DECL]
Blk FB blk.fb
[PROGRAM]
        A   I 4.0
        JC  = set
        JU  FB Blk
        JU  FB Blk
        BE
set:    =   Q 17.0
        BE
[END]
"""
    block = "[PROGRAM]\n        AN  Q 17.1\n        =   Q 17.1\n"
    files = {"main.asi": from_string("main.asi", text), "blk.fb": from_string("blk.fb", block)}
    result = check_source(files["main.asi"], read=lambda p: files[p.name],
                          exists=lambda p: p.name in files)
    assert not result.has_errors, result.diagnostics
    image = build_image(compile_program(result.program))
    board = _running(image)
    answer = latest_cycle(board)
    lines = CycleLines.from_json(answer).lines
    assert not lines[SourceLine("main.asi", 12)].ran  # on: = Q 17.0
    assert lines[SourceLine("main.asi", 12)].rlo is None
    assert lines[SourceLine("blk.fb", 2)].runs == 2
    assert lines[SourceLine("main.asi", 7)].runs == 1
    assert lines[SourceLine("main.asi", 7)].operand == 0  # I 4.0
    board.bus.at(4)[0].inputs = 1
    lines = CycleLines.from_json(latest_cycle(board)).lines
    assert lines[SourceLine("main.asi", 12)].ran and lines[SourceLine("main.asi", 12)].rlo == 1
    assert not lines[SourceLine("blk.fb", 2)].ran
    assert lines[SourceLine("main.asi", 7)].operand == 1


def _running(image, slaves=((4, 0x0), (17, 0x8))) -> Pc2Board:
    bus = AsiBus([Slave(a, io, 0x0) for a, io in slaves])
    state = Pc2Board(bus=bus).nonvolatile()
    configuration = image.configuration
    state.update(
        eeprom=image.to_bytes().hex(), control_flags=image.flags | ControlFlag.START,
        configuration_mode=False, lps=configuration.projected(),
        pcd=configuration.pcd.hex(), pp=configuration.pp.hex(),
    )
    board = Pc2Board.from_nonvolatile(state)
    board.advance(50)
    assert board.control_state is ControlState.RUNNING, board.stop_message
    return board


FOLLOW = """\
[SETUP]
4: iiii, 0
17: oooo, 0
[PROGRAM]
        A   I 4.0
        =   Q 17.3
        BE
[END]
"""


def test_a_settled_program_is_woken_for_its_cycle_and_runs_untraced_afterwards():
    image = build(from_string("p.asi", FOLLOW)).image
    board = _running(image)
    runner = board.program
    board.advance(100)
    cycles = runner.cpu.cycles
    board.advance(100)
    assert runner.cpu.cycles == cycles, "the settled program's cycles are skipped"
    answer = latest_cycle(board)
    assert answer["master_ms"] is not None and answer["note"] == ""
    assert [e["line"] for e in answer["lines"] if e["ran"]] == [5, 6, 7]
    board.advance(100)  # the master probes a few cycles before it skips again
    cycles = runner.cpu.cycles
    board.advance(100)
    assert runner.cpu.cycles == cycles, "the settled program's cycles are skipped again"


def test_a_stopped_program_and_an_image_without_line_map():
    image = build(from_string("p.asi", FOLLOW)).image
    stopped = _running(image)
    set_start(Pc2Transport(Pc2Driver(EmulatedPort(stopped))), start=False)
    stopped.advance(10)
    answer = latest_cycle(stopped)
    assert answer["state"] != "running" and answer["note"] == "the program is not running"
    assert answer["lines"] and not any(e["ran"] for e in answer["lines"])
    bare = _running(replace(image, line_map=LineMap()))
    answer = latest_cycle(bare)
    assert answer["lines"] == [] and "no line map" in answer["note"]


def test_a_cycle_that_times_out_while_recorded():
    text = FOLLOW.replace("        =   Q 17.3\n", "        JC  = spin\n        BE\n"
                          "spin:   A   I 4.1\n        JU  = spin\n")
    image = build(from_string("loop.asi", text)).image
    board = _running(image)
    board.bus.at(4)[0].inputs = 1
    answer = latest_cycle(board)
    assert answer["state"] == "halted"
    assert answer["note"] == "the program stopped before its cycle ended"
    assert not any(e["ran"] for e in answer["lines"])


def test_the_answer_reads_back_and_a_malformed_one_is_an_error():
    image = build(from_string("p.asi", FOLLOW)).image
    lines = CycleLines.from_json(latest_cycle(_running(image)))
    assert lines.identity == image.identity_hex and lines.state == "running"
    assert lines.lines[SourceLine("p.asi", 6)].rlo == 0
    with pytest.raises(UserError, match="malformed"):
        CycleLines.from_json({"lines": [{"file": "p.asi"}]})


def _trace_csv(rows_text: str) -> dict[SourceLine, Row]:
    """The last cycle of a ``--trace-il`` CSV, each line's last run."""
    rows = list(csv.DictReader(io.StringIO(rows_text)))
    last = max(int(r["cycle"]) for r in rows)
    return _last_runs([
        (r["file"], int(r["line"]), int(r["rlo"]), int(r["accu1"]), int(r["accu2"]),
         None if r["operand"] == "" else int(r["operand"]))
        for r in rows if int(r["cycle"]) == last
    ])


def test_a_live_board_answers_over_its_socket_as_sim_trace_il_shows(tmp_path: Path):
    """The fb demo with I 1.0 and I 1.2 on: the latch set, Count3 called once, GetLAS."""
    for name in ("fb.asi", "latch.fb", "count3.fb"):
        (tmp_path / name).write_bytes((DEMOS / name).read_bytes())
    (tmp_path / "on.scenario.toml").write_text(
        '[[step]]\nat_ms = 0\nset = { "I 1.0" = 1, "I 1.2" = 1 }\n'
    )
    runner = CliRunner()
    traced = runner.invoke(main, [
        "sim", str(tmp_path / "fb.asi"), "--scenario", str(tmp_path / "on.scenario.toml"),
        "--duration", "200ms", "--trace-il", str(tmp_path / "trace.csv"),
    ])
    assert traced.exit_code == 0, traced.output
    expected = _trace_csv((tmp_path / "trace.csv").read_text())
    state = tmp_path / "state"
    with background_live(0x300, state, identity={"command": "test"}):
        def cli(*args: str) -> None:
            result = runner.invoke(main, [*args, "--state-dir", str(state)])
            assert result.exit_code == 0, result.output

        cli("download", str(tmp_path / "fb.asi"), "--start")
        cli("bus", "match")
        cli("bus", "inputs", "I 1.0=1", "I 1.2=1")
        time.sleep(0.3)
        with open_board(MasterAddress(state_dir=state)) as master:
            answer = master.emulated("lines")
    assert answer["state"] == "running"
    assert _ran(answer) == expected
    assert expected[SourceLine("latch.fb", 9)][5] == 1, "the latch is set (F 20.2)"
