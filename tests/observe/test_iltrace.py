"""The per-line trace (``--trace-il``) against the reference interpreter.

The trace reads the IL registers from the 8051 at the line map's boundaries; the
reference interpreter (``il.reference``) runs the same program on the AST and reports
each statement as it starts. Row for row, per cycle, the two must name the same lines
with the same single-bit register, ACCU1 and ACCU2.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path, PurePath

from click.testing import CliRunner
from hypothesis import assume
from hypothesis import strategies as st
from il_strategies import traceable_sources
from sized import check, sizes

from asictl.build import build_file
from asictl.cli import main
from asictl.il.oracle import Interpreter
from asictl.observe.iltrace import ILTracer
from asictl.observe.view import ProgramView
from asictl.runtime.line_map import SourceLine
from asictl.runtime.program_map import LoadedProgram
from asictl.runtime.runner import CycleTimeout, ProgramRunner

#: the default run's sample, and the long run's (``-m slow``)
EXAMPLES = int(os.environ.get("ASICTL_TRACE_EXAMPLES", "50"))
LONG_EXAMPLES = int(os.environ.get("ASICTL_TRACE_EXAMPLES", "300"))


class ModelFirmware:
    """The same deterministic stand-in for the firmware blocks on both sides."""

    def call(self, name: str, pseg: bytearray) -> None:
        h = (sum(pseg[:4]) * 7 + len(name)) & 0xFF
        pseg[0] = 0 if h % 3 else 0x80
        pseg[1] = (pseg[1] ^ h) & 0xFF


inputs_runs = st.lists(st.binary(min_size=16, max_size=16), min_size=1, max_size=4)


def _line(statement: object) -> SourceLine | None:
    span = getattr(statement, "span", None)
    return None if span is None else SourceLine(PurePath(span.file).name, span.line)


@sizes(EXAMPLES, LONG_EXAMPLES)
def test_trace_rows_agree_with_the_reference_interpreter(examples: int) -> None:
    check(examples, trace_rows_agree_with_the_reference_interpreter,
          traceable_sources(), inputs_runs)


def trace_rows_agree_with_the_reference_interpreter(files: dict[str, str], runs) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in files.items():
            (Path(tmp) / name).write_text(text)
        built = build_file(Path(tmp) / "main.asi")
    assume(not built.has_errors)
    assert built.compiled is not None and built.program is not None
    compiled = built.compiled
    line_map = compiled.line_map
    with_code = set(line_map.lines())
    runner = ProgramRunner(
        LoadedProgram(compiled.code, compiled.pmap, compiled.entry_points),
        firmware=ModelFirmware(),
    )
    tracer = ILTracer(runner, line_map, texts=files, clock=lambda: 0.0,
                      view=ProgramView(runner, lambda operand: 0))
    tracer.hooks.install()
    interp = Interpreter(built.program, firmware=ModelFirmware())
    events: list[tuple[SourceLine | None, tuple[int, int, int, int]]] = []

    def registers() -> tuple[int, int, int, int]:
        s = interp.state
        return int(s.rlo), s.accu1, s.accu2, s.constant

    interp.on_statement = lambda statement: events.append((_line(statement), registers()))
    for cycle, inputs in enumerate(runs, 1):
        events.clear()
        try:
            interp.cycle(inputs)
        except CycleTimeout:
            return
        events.append((None, registers()))  # the cycle's end
        expected = [
            (line, *events[i + 1][1])
            for i, (line, _) in enumerate(events[:-1])
            if line is not None and line in with_code
        ]
        tracer.rows.clear()
        runner.cycle(inputs)
        got = [(row.line, row.rlo, row.accu1, row.accu2, row.constant) for row in tracer.rows]
        assert all(row.cycle == cycle for row in tracer.rows)
        assert got == expected, f"cycle {cycle}"


# ------------------------------------------------------------------ the command line


LOGIC = """\
[SETUP]
1: iiii, 0
2: oooo, 0
[PROGRAM]
    A   I 1.0
    AN  I 1.1
    O   I 1.2
    =   Q 2.0
"""


def test_trace_il_rows_of_a_logic_program_have_the_rlo_its_inputs_imply(tmp_path: Path):
    (tmp_path / "logic.asi").write_text(LOGIC)
    (tmp_path / "logic.scenario.toml").write_text(
        '[master]\ncycle_ms = 10\n'
        '[[step]]\nat_ms = 0\nset = { "I 1.0" = 1 }\n'
        '[[step]]\nat_ms = 20\nset = { "I 1.1" = 1 }\n'
        '[[step]]\nat_ms = 40\nset = { "I 1.2" = 1 }\n'
        '[[step]]\nat_ms = 50\nexpect = { "Q 2.0" = 1 }\n'
    )
    out = tmp_path / "lines.csv"
    result = CliRunner().invoke(main, ["sim", str(tmp_path / "logic.asi"), "--trace-il", str(out)])
    assert result.exit_code == 0, result.output
    rows = [line.split(",") for line in out.read_text().splitlines()]
    assert rows[0] == ["time_ms", "file", "line", "rlo", "accu1", "accu2", "source", "cycle",
                       "operand", "constant"]
    by_time: dict[str, list[tuple[str, str, str]]] = {}
    for row in rows[1:]:
        by_time.setdefault(row[0], []).append((row[2], row[3], row[6]))
    # I 1.0 from 0, I 1.1 from 20, I 1.2 from 40: (A I1.0, AN I1.1, O I1.2) line by line
    rlo = {"0": "111", "10": "111", "20": "100", "30": "100", "40": "101"}
    for time_ms, bits in rlo.items():
        lines = by_time[time_ms]
        assert [n for n, _, _ in lines] == ["5", "6", "7", "8"], (time_ms, lines)
        assert "".join(r for _, r, _ in lines[:3]) == bits, (time_ms, lines)
        assert lines[3][1] == bits[2] and lines[3][2] == "=   Q 2.0"


def test_trace_il_window(tmp_path: Path):
    (tmp_path / "logic.asi").write_text(LOGIC)
    out = tmp_path / "lines.csv"
    result = CliRunner().invoke(main, [
        "sim", str(tmp_path / "logic.asi"), "--set", "I 1.0=1", "--duration", "1s",
        "--trace-il", str(out), "--from", "250ms", "--to", "300ms",
    ])
    assert result.exit_code == 0, result.output
    times = {float(line.split(",")[0]) for line in out.read_text().splitlines()[1:]}
    assert times and min(times) >= 250 and max(times) <= 300
