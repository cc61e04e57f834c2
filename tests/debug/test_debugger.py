"""The IL debugger: driven as an object, through ``--batch``, and once in a real terminal."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.cli import main
from asictl.debug.debugger import Debugger
from asictl.sim.session import prepare

ROOT = Path(__file__).resolve().parents[2]
DEMOS = ROOT / "demos"

COUNTER = """\
[SETUP]
1: iiii, 0
2: oooo, 0
[PROGRAM]
    A   I 1.0
    L   KC 4095
    S   C 0
***
    A   I 1.1
    CD  C 0
***
    A   I 1.2
    L   KT 500
    S   T 1
"""
SCENARIO = """\
[master]
cycle_ms = 5
[[step]]
at_ms = 0
set = { "I 1.0" = 1, "I 1.2" = 1 }
[[step]]
at_ms = 10
set = { "I 1.0" = 0, "I 1.1" = 1 }
[[step]]
at_ms = 100
expect = { "CV 0" = 1 }
"""


class Session:
    """A debugger whose output is kept; ``do`` runs a command and returns its output."""

    def __init__(self, program: Path, scenario: Path | None = None) -> None:
        self.lines: list[str] = []
        self.debugger = Debugger(prepare(program, scenario), self.lines.append)

    def do(self, command: str) -> list[str]:
        start = len(self.lines)
        assert self.debugger.execute(command)
        return self.lines[start:]


@pytest.fixture
def counter(tmp_path: Path) -> Session:
    program = tmp_path / "count.asi"
    program.write_text(COUNTER)
    scenario = tmp_path / "count.scenario.toml"
    scenario.write_text(SCENARIO)
    session = Session(program, scenario)
    yield session
    session.debugger.close()


def test_break_continue_and_print(counter: Session):
    assert counter.do("break 6") == ["breakpoint 1 at count.asi:6: L   KC 4095"]
    out = counter.do("continue")
    assert out[0] == "breakpoint 1, count.asi:6, master time 0 ms, cycle 1"
    # I 1.0 was set at time 0: the first cycle sees it (the timing contract)
    assert counter.do("print RLO, I 1.0, CV 0") == ["RLO = 1", "I 1.0 = 1", "CV 0 = 0"]
    assert counter.do("step")[0] == "count.asi:7, master time 0 ms, cycle 1"
    assert counter.do("step")[0] == "count.asi:9, master time 0 ms, cycle 1"
    assert counter.do("print CV 0, C 0") == ["CV 0 = 4095", "C 0 = 1 (value 4095)"]
    assert counter.do("continue")[0] == "breakpoint 1, count.asi:6, master time 5 ms, cycle 2"


def test_closing_at_a_breakpoint_ends_the_worker_at_once(counter: Session):
    """The worker paused inside a program cycle unwinds when the session ends; it used
    to be caught as a fault of the program and wait for a command that never came."""
    counter.do("break 6")
    counter.do("continue")
    workers = [t for t in threading.enumerate() if t.name != threading.current_thread().name]
    assert workers
    counter.debugger.close()
    assert not any(t.is_alive() for t in workers)


def test_display_shows_its_expressions_at_every_stop(counter: Session):
    assert counter.do("display CV 0, RLO") == ["1: CV 0 = 0", "2: RLO = 0"]
    counter.do("break 10 if RLO=1")
    stop = counter.do("continue")
    assert stop[0] == "breakpoint 1, count.asi:10, master time 10 ms, cycle 3"
    assert stop[-2:] == ["1: CV 0 = 4095", "2: RLO = 1"]
    after = counter.do("next")[-2:]
    assert after == ["1: CV 0 = 4094", f"2: RLO = {counter.debugger.value('RLO')}"]
    assert counter.do("undisplay 2") == ["display 2 (RLO) removed"]
    assert counter.do("display") == ["1: CV 0 = 4094"]
    assert counter.do("display Nope")[0].startswith("error: 'Nope' is not an operand")
    assert counter.debugger.displays == ["CV 0"]  # a mistake is not added
    counter.do("undisplay")
    assert counter.do("cycle") == ["cycle 4 starts at 15 ms"]


def test_conditional_breakpoints_cycles_and_time(counter: Session):
    counter.do("break 10 if RLO=1")  # CD C 0 with the register 1: from 10 ms on
    assert counter.do("continue")[0] == "breakpoint 1, count.asi:10, master time 10 ms, cycle 3"
    assert counter.do("print CV 0") == ["CV 0 = 4095"]
    assert counter.do("next")[0].startswith("count.asi:12,")
    assert counter.do("print CV 0") == ["CV 0 = 4094"]
    counter.do("delete")
    assert counter.do("cycle") == ["cycle 4 starts at 15 ms"]
    counter.do("set I 1.2=0")  # the timer is loaded for the last time at 15 ms
    assert counter.do("time 20ms") == ["master time 35 ms (cycle 8)"]
    remaining = counter.debugger.value("TV 1")
    assert 470 <= remaining <= 490  # about two 10 ms ticks since 15 ms (the clock has its phase)
    assert counter.do("print T 1") == [f"T 1 = 1 (remaining {remaining} ms)"]
    counter.do("set I 1.1=0")
    out = counter.do("continue")
    assert out[0] == f"{counter.debugger.prepared.scenario.file}:11: at 100 ms: CV 0 expected " \
        "1, got 4089"
    assert out[1] == "end of the simulation at 100 ms (1 expectations checked, 1 failed)"
    assert counter.do("continue") == [
        "error: the simulation has ended (at 100 ms); quit, or start again"]


def test_next_steps_over_a_block_call_and_step_goes_into_it():
    session = Session(DEMOS / "fb.asi", DEMOS / "fb.scenario.toml")
    try:
        session.do("break 31")
        session.do("continue")
        assert session.do("next")[0].startswith("fb.asi:33,")
        session.do("continue")
        out = session.do("step")
        assert out[0].startswith("latch.fb:8 (called from fb.asi:31),"), out
        assert session.do("where")[0].startswith("latch.fb:8 (called from fb.asi:31)")
        session.do("break latch.fb:17")
        assert session.do("continue")[0].startswith("breakpoint 2, latch.fb:17")
        assert session.do("step")[0].startswith("fb.asi:33,")
    finally:
        session.debugger.close()


def test_mistakes_are_refused_with_a_reason(counter: Session):
    assert counter.do("break 99") == ["error: count.asi has no code at or after line 99"]
    assert counter.do("break x.fb:1")[0].startswith("error: no code from 'x.fb'")
    assert counter.do("break 6 if Q 99.0=1")[0].startswith("error: 'Q 99.0'")
    assert counter.do("print Q 2.0, X 1")[1].startswith("error: 'X 1'")
    assert counter.do("set Q 2.0=1")[0].startswith("error: 'Q 2.0' cannot be set")
    assert counter.do("frobnicate") == ["error: unknown command 'frobnicate' ('help' lists them)"]
    assert counter.do("break ²") == ["error: '²' is not a line: 12 or count.asi:12"]
    assert counter.do("delete ²")[0].startswith("error: ")
    assert counter.debugger.failed


def test_set_and_conditions_read_values_as_every_tool_does(counter: Session):
    """``set`` is the reader of ``asictl write``, ``--set`` and scenarios
    (observe.operands): a slave's four inputs at once, values in 0x, 0b and IL forms."""
    assert counter.do("set I 1=0b0101") == [
        "I 1 = 5 (the program sees it from its next cycle)"]
    assert counter.do("set FY 10=0Ah") == ["FY 10 = 10 (the program sees it from its next cycle)"]
    counter.do("time 1ms")
    assert counter.do("print I 1, I 1.2, FY 10") == ["I 1 = 5", "I 1.2 = 1", "FY 10 = 10 (0Ah)"]
    counter.do("break 10 if CV 0>=0FFFh")
    assert counter.do("continue")[0].startswith("breakpoint 1, count.asi:10,")
    assert counter.do("set I 1=16") == [
        "error: 'I 1': value 16 out of range 0..15 (four data bits)"]
    assert counter.do("set FY 10=ten") == [
        "error: 'FY 10': 'ten' is not a number (such as 11, 0xB, 0Bh or 0b1011)"]
    assert counter.do("set")[0] == "error: expected OPERAND=VALUE, such as 'I 1.0=1'"


def test_symbols_in_print_and_set(tmp_path: Path):
    program = tmp_path / "count.asi"
    program.write_text(COUNTER)
    (tmp_path / "count.symbols.toml").write_text('Load = "I 1.0"\nParts = "C 0"\n')
    session = Session(program)
    try:
        session.do("set Load=1")
        session.do("time 1ms")
        assert session.do("print Parts, CV Parts") == ["Parts = 1 (value 4095)",
                                                      "CV Parts = 4095"]
    finally:
        session.debugger.close()


def test_batch_mode(tmp_path: Path):
    program = tmp_path / "count.asi"
    program.write_text(COUNTER)
    commands = tmp_path / "cmds.txt"
    commands.write_text("break 6   # the load\ncontinue\nprint RLO\nquit\nprint RLO\n")
    result = CliRunner().invoke(main, ["debug", str(program), "--set", "I 1.0=1",
                                       "--batch", str(commands)])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert "(asictl) break 6" in lines
    assert lines[lines.index("(asictl) print RLO") + 1] == "RLO = 1"
    assert lines[-1] == "(asictl) quit"  # nothing after quit runs
    commands.write_text("break 99\n")
    assert CliRunner().invoke(main, ["debug", str(program), "--batch", str(commands)]
                              ).exit_code == 1


# ------------------------------------------------------------------ a real terminal


def _tmux() -> str:
    path = shutil.which("tmux")
    if path:
        return path
    message = "tmux is missing (apt-get install -y tmux): the terminal test of asictl debug"
    if os.environ.get("CI"):
        pytest.fail(message)
    pytest.skip(message)


def test_tab_completes_commands_files_and_what_names_a_value(tmp_path: Path):
    program = tmp_path / "count.asi"
    program.write_text(COUNTER)
    (tmp_path / "count.symbols.toml").write_text('Start = "I 1.0"\nDown = "I 1.1"\n'
                                                 'Lamp = "Q 2.0"\n')
    session = Session(program)
    complete = session.debugger.completions
    try:
        assert complete("pr") == ["print"]
        assert complete("  c") == ["continue", "cycle"]
        assert "quit" in complete("") and "p" not in complete("")  # names, not short ones
        assert complete("print ") == ["ACCU1", "ACCU2", "C", "CV", "Down", "I", "KREG",
                                      "Lamp", "RLO", "Start", "T"]
        assert complete("print st") == ["Start"]  # as names are read: any case
        assert complete("display RLO, I ") == ["1.0", "1.1", "1.2"]  # the program's
        assert complete("p CV ") == ["0"] and complete("print Q ") == []
        assert complete("set ") == ["Down", "I", "Start"]  # what can be set: no Lamp
        assert complete("break co") == ["count.asi:"]
        assert complete("break count.asi:6 ") == ["if"]
        assert complete("break 6 if Start and n") == ["not"]
        assert complete("break 6 if R") == ["RLO"]
        assert complete("time 1") == complete("frobnicate ") == []
        assert session.do("break count.asi: 6")[0].startswith("breakpoint 1 at count.asi:6")
    finally:
        session.debugger.close()


def test_the_completer_gives_readline_the_matches_one_by_one(counter: Session):
    from asictl.cli.debug import completer

    class Line:
        """The line typed so far, the cursor after ``before``."""

        def __init__(self, before: str, after: str = "") -> None:
            self.before, self.after = before, after

        def get_line_buffer(self) -> str:
            return self.before + self.after

        def get_endidx(self) -> int:
            return len(self.before)

    complete = completer(counter.debugger, Line("print CV", " 0"))
    assert [complete("CV", state) for state in range(3)] == ["CV ", None, None]
    assert complete("C", 0) == "CV "  # state 0 asks again: the line decides, not the text
    assert completer(counter.debugger, Line("break co"))("co", 0) == "count.asi:"  # no space


def test_the_debugger_in_a_real_terminal_with_history(tmp_path: Path):
    tmux = _tmux()
    program = tmp_path / "count.asi"
    program.write_text(COUNTER)
    (tmp_path / "count.scenario.toml").write_text(SCENARIO)
    history = tmp_path / "history"
    socket = f"asictl-test-{uuid.uuid4().hex[:8]}"
    env = {key: value for key, value in os.environ.items() if key not in ("COLUMNS", "LINES")}
    env.update(PYTHONPATH=str(ROOT / "src"), ASICTL_HISTORY=str(history), HOME=str(tmp_path),
               TERM="xterm")
    command = f"{sys.executable} -m asictl debug {program}"
    subprocess.run([tmux, "-L", socket, "new-session", "-d", "-s", "t", "-x", "120", "-y", "50",
                    command], env=env, check=True)

    def keys(*sent: str) -> None:
        subprocess.run([tmux, "-L", socket, "send-keys", "-t", "t", *sent], check=True)

    def screen_until(text: str) -> str:
        deadline = time.monotonic() + 30
        while True:
            screen = subprocess.run([tmux, "-L", socket, "capture-pane", "-p", "-t", "t"],
                                    capture_output=True, text=True).stdout
            if text in screen or time.monotonic() > deadline:
                return screen
            time.sleep(0.1)

    try:
        assert "(asictl)" in screen_until("(asictl)")
        keys("break 6", "Enter")
        keys("continue", "Enter")
        screen = screen_until("breakpoint 1, count.asi:6")
        assert "breakpoint 1, count.asi:6, master time 0 ms, cycle 1" in screen
        keys("print CV 0", "Enter")
        assert "CV 0 = 0" in screen_until("CV 0 = 0")
        keys("continue", "Enter")
        screen_until("master time 5 ms, cycle 2")
        keys("Up", "Up", "Enter")  # readline history: 'print CV 0' again
        screen = screen_until("CV 0 = 4095")
        assert "CV 0 = 4095" in screen, screen
        keys("pr", "Tab", "CV", "Space", "Tab", "Enter")  # the command and the address
        deadline = time.monotonic() + 30
        while screen.count("CV 0 = 4095") < 2 and time.monotonic() < deadline:
            screen = screen_until("")
        assert screen.count("(asictl) print CV 0\nCV 0 = 4095") == 2, screen
        keys("quit", "Enter")
        deadline = time.monotonic() + 10
        while not history.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        assert "print CV 0" in history.read_text()
    finally:
        subprocess.run([tmux, "-L", socket, "kill-server"], capture_output=True)


def test_finish_runs_out_of_a_block_and_hit_counts_skip_hits():
    session = Session(DEMOS / "fb.asi", DEMOS / "fb.scenario.toml")
    try:
        assert session.do("finish") == [
            "error: not inside a function block: finish runs out of one"]
        session.debugger.add_breakpoint("latch.fb:8", hit_condition="3")
        assert session.do("continue")[0].startswith("breakpoint 1, latch.fb:8 (called from "
                                                     "fb.asi:31), master time")
        assert session.debugger.cycle == 3  # the third hit: the third cycle
        assert session.do("finish")[0].startswith("fb.asi:33,")
    finally:
        session.debugger.close()


def test_the_debugger_stops_where_the_program_stops(tmp_path: Path):
    program = tmp_path / "loop.asi"
    program.write_text("[SETUP]\n1: iiii, 0\n[PROGRAM]\n    A   I 1.0\n    JC  = stuck\n"
                       "    BE\nstuck:\n    A   I 1.1\n    JU  = stuck\n")
    lines: list[str] = []
    debugger = Debugger(prepare(program, None, sets=["I 1.0=1"], duration_ms=50.0),
                        lines.append)
    try:
        debugger.execute("continue")
        assert lines[-3].startswith("at 0 ms: program stopped: loop.asi:9: program cycle "
                                    "time-out")
        assert lines[-2].startswith("loop.asi:9, master time ")  # paused at the loop
        assert lines[-1] == "     9 | JU  = stuck"
        assert debugger.pause is not None and debugger.pause.kind == "fault"
        debugger.execute("continue")
        assert lines[-1].startswith("end of the simulation at 50 ms")
    finally:
        debugger.close()


def test_an_empty_line_repeats_the_last_step_as_gdb_does(counter: Session, monkeypatch):
    """At the prompt, Enter repeats step, next, continue, cycle, finish or time; not print."""
    from asictl.cli import debug as cli_debug

    typed = iter(["break 6", "continue", "", "print CV 0", "", "quit"])
    monkeypatch.setattr("builtins.input", lambda prompt="": next(typed))
    monkeypatch.setattr(cli_debug, "_history_file", lambda: Path(os.devnull) / "none")
    echoed: list[str] = []
    monkeypatch.setattr(cli_debug.click, "echo", lambda text="", **_: echoed.append(str(text)))
    cli_debug._interactive(counter.debugger)
    stops = [line for line in counter.lines if line.startswith("breakpoint 1, count.asi:6")]
    assert [s.split(", cycle ")[1] for s in stops] == ["1", "2"]  # not again after print
    assert len([line for line in counter.lines if line.startswith("CV 0 = ")]) == 1


def test_print_shows_the_constant_register(tmp_path: Path):
    """L KT/KC/KP load the constant register and leave the accumulators alone; KREG holds
    ticks of 10 ms, and beside them the time they make as a timer's remaining time is
    shown (``24.8 s``, never ``24810 ms``)."""
    program = tmp_path / "k.asi"
    program.write_text("[SETUP]\n1: iiii, 0\n[PROGRAM]\n    L KB 7\n    L KT 24810\n"
                       "    A I 1.0\n    S T 1\n    BE\n")
    session = Session(program)
    try:
        session.do("break 6")
        session.do("continue")
        assert session.do("print KREG, ACCU1, ACCU2") == [
            "KREG = 2481 (9B1h; as L KT 2481 ticks, 24.8 s, as L KC 2481, as L KP 27.1)",
            "ACCU1 = 7 (0007h)", "ACCU2 = 0 (0000h)",
        ]
        assert session.debugger.value("KREG") == 2481
        session.do("set I 1.0=1")
        session.do("continue")
        session.do("continue")  # T 1 started in the cycle before
        [timer] = session.do("print T 1")
        assert timer.startswith("T 1 = 1 (remaining 24.") and timer.endswith(" s)"), timer
    finally:
        session.debugger.close()


def test_time_takes_a_unit_as_every_duration_does(counter: Session):
    """``time 100`` could be 100 ms or 100 s: refused with both readings, as a scenario's
    ``at = "100"`` and ``sim --duration 100`` are."""
    assert counter.do("time 100") == ["error: '100' has no unit: give a unit: 100ms or 100s"]
    assert "master time 20 ms" in " ".join(counter.do("time 20ms"))
