"""One condition, written once, in every tool that takes one: a plant rule, a property,
a debugger breakpoint, an editor's conditional breakpoint (the DAP) and a watch table.
Each host reads it the same way and means the same by it; a mistake in it is reported
with the same words, pointing at the same token, in each host's own form (E410 at
FILE:LINE:COL in a file, an ``error:`` line and a caret in the debugger and on the
command line, a refused breakpoint in the DAP).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner
from dap_client import DapClient

from asictl.cli import main
from asictl.debug.debugger import Debugger
from asictl.observe.condition import ConditionError, parse_condition
from asictl.prove.engine import Verdict
from asictl.prove.session import Invalid, prove
from asictl.sim.session import prepare

#: A motor that holds itself on from Start until Stop, and its lamp.
PROGRAM = """\
[SETUP]
1: iiii, 0
2: oooo, 0
[PROGRAM]
        A   I 1.0       ; start
        O   Q 2.0       ; holds itself
        AN  I 1.2       ; stop
        =   Q 2.0
***
        A   Q 2.0
        =   Q 2.1       ; lamp
***
"""
LAMP = 10  # A Q 2.0: after the motor's output is written in the same cycle
SYMBOLS = 'Start = "I 1.0"\nStop = "I 1.2"\nForward = "Q 2.0"\n'
#: Symbols, a single =, xor, false, not, parentheses: written once for every host.
CONDITION = "Forward = 1 and not (Stop xor false)"
#: The same with a mistake: it stops after xor.
BAD = "Forward = 1 and not (Stop xor"
MESSAGE = "expected an operand, a number or '(', found the end"


def scenario(condition: str) -> str:
    return f"""program = "p.asi"
[master]
cycle_ms = 5
[[plant]]
type = "rule"
when = "{condition}"
set = {{ "F 5.0" = 1 }}
[[step]]
at_ms = 5
expect = {{ "F 5.0" = 0 }}
[[step]]
at_ms = 10
set = {{ Start = 1 }}
[[step]]
at_ms = 50
expect = {{ "F 5.0" = 1 }}
"""


def properties(condition: str) -> str:
    return f"""program = "p.asi"
[[property]]
name = "forward runs"
reachable = "{condition}"
[[property]]
name = "forward never runs"
never = "{condition}"
"""


@pytest.fixture
def program(tmp_path: Path) -> Path:
    path = tmp_path / "p.asi"
    path.write_text(PROGRAM)
    (tmp_path / "p.symbols.toml").write_text(SYMBOLS)
    return path


def watch(table: Path, *more: str) -> list[int]:
    """The values ``asictl watch`` prints for ``table``'s entries over 50 ms of master
    time on the board in $ASICTL_STATE_DIR."""
    result = CliRunner().invoke(main, ["watch", "--table", str(table), "--duration", "50ms",
                                       "--format", "json", *more])
    assert result.exit_code == 0, result.output
    return [json.loads(line)["value"] for line in result.stdout.splitlines()]


def column_in(text: str, key: str) -> int:
    """The 1-based column, in the line ``key = "..."`` of ``text``, of where BAD goes wrong."""
    line = next(line for line in text.split("\n") if line.startswith(f"{key} = "))
    return line.index('"') + 2 + len(BAD)


def test_one_condition_means_the_same_in_every_host(program: Path, client: DapClient):
    tmp = program.parent
    # a plant rule: F 5.0 is set once the motor runs forward, not before
    (tmp / "p.scenario.toml").write_text(scenario(CONDITION))
    result = CliRunner().invoke(main, ["sim", str(program)])
    assert result.exit_code == 0, result.output
    # a property: reachable, and so "never" is refuted
    (tmp / "p.props.toml").write_text(properties(CONDITION))
    verdicts = {o.prop.name: o.verdict for o in prove(tmp / "p.props.toml").outcomes}
    assert verdicts == {"forward runs": Verdict.REACHED, "forward never runs": Verdict.REFUTED}
    # the debugger: stops in the cycle that first sees Start (set at 10 ms)
    lines: list[str] = []
    debugger = Debugger(prepare(program, tmp / "p.scenario.toml"), lines.append)
    try:
        debugger.execute(f"break {LAMP} if {CONDITION}")
        debugger.execute("continue")
        assert any(line.startswith(f"breakpoint 1, p.asi:{LAMP}, master time 10 ms")
                   for line in lines), lines
    finally:
        debugger.close()
    # the DAP: a verified conditional breakpoint, hit at the same time
    client.request("initialize", {"adapterID": "asictl", "linesStartAt1": True})
    client.request("launch", {"program": str(program)})
    client.wait_event("initialized")
    placed = client.request("setBreakpoints", {"source": {"path": str(program)}, "breakpoints": [
        {"line": LAMP, "condition": CONDITION}]})["breakpoints"]
    client.request("configurationDone")
    assert placed[0]["verified"]
    stop = client.stopped()
    assert stop["line"] == LAMP and stop["reason"] == "breakpoint"
    assert client.request("evaluate", {"expression": "Forward", "context": "hover"})[
        "result"] == "1"


def test_the_same_condition_in_a_watch_table(program: Path, monkeypatch: pytest.MonkeyPatch):
    tmp = program.parent
    monkeypatch.setenv("ASICTL_STATE_DIR", str(tmp / "state"))
    run = CliRunner().invoke
    assert run(main, ["download", str(program), "--start"]).exit_code == 0
    assert run(main, ["bus", "match"]).exit_code == 0
    table = tmp / "p.watch.toml"
    table.write_text(f'watch = ["{CONDITION}"]\n')
    assert watch(table) == [0]  # the motor stands
    assert run(main, ["bus", "inputs", "Start=1"]).exit_code == 0
    assert watch(table) == [1]  # it runs forward, Stop is not pressed
    assert run(main, ["bus", "inputs", "Start=0", "Stop=1"]).exit_code == 0
    assert watch(table) == [0]


def test_a_mistake_reads_the_same_in_every_host(program: Path, client: DapClient):
    tmp = program.parent
    with pytest.raises(ConditionError) as caught:
        parse_condition(BAD)
    assert (caught.value.message, caught.value.offset) == (MESSAGE, len(BAD))
    # a plant rule and a property: E410 at the token's column inside the string
    text = scenario(BAD)
    (tmp / "p.scenario.toml").write_text(text)
    result = CliRunner().invoke(main, ["sim", str(program)])
    assert result.exit_code == 2
    assert f"p.scenario.toml:6:{column_in(text, 'when')}: error: {MESSAGE} [E410]" in (
        result.output)
    text = properties(BAD)
    (tmp / "p.props.toml").write_text(text)
    with pytest.raises(Invalid) as invalid:
        prove(tmp / "p.props.toml")
    at = column_in(text, "reachable")
    assert f"p.props.toml:4:{at}: error: {MESSAGE} [E410]" in invalid.value.text
    assert f"p.props.toml:7:{column_in(text, 'never')}: error: {MESSAGE}" in invalid.value.text
    assert "\n" + " " * (at + 1) + "^\n" in invalid.value.text  # under the closing quote
    # the debugger: an error line, the condition and a caret under where it went wrong
    lines: list[str] = []
    debugger = Debugger(prepare(program, None), lines.append)
    try:
        start = len(lines)
        debugger.execute(f"break {LAMP} if {BAD}")
    finally:
        debugger.close()
    caret = "  " + " " * len(BAD) + "^"
    assert lines[start].split("\n") == [f"error: {MESSAGE}", f"  {BAD}", caret]
    assert debugger.failed
    # the DAP: the breakpoint is refused with the same words
    client.request("initialize", {"adapterID": "asictl", "linesStartAt1": True})
    client.request("launch", {"program": str(program), "noScenario": True})
    client.wait_event("initialized")
    placed = client.request("setBreakpoints", {"source": {"path": str(program)}, "breakpoints": [
        {"line": LAMP, "condition": BAD}]})["breakpoints"]
    assert not placed[0]["verified"]
    assert placed[0]["message"].split("\n")[0] == MESSAGE


def test_a_mistake_in_a_watch_reads_the_same(program: Path, monkeypatch: pytest.MonkeyPatch):
    tmp = program.parent
    monkeypatch.setenv("ASICTL_STATE_DIR", str(tmp / "state"))
    assert CliRunner().invoke(main, ["download", str(program)]).exit_code == 0
    # in a watch table: E410 at the token's column inside the string, as in any file
    text = f'watch = [\n  "Start",\n  "{BAD}",\n]\n'
    (tmp / "b.watch.toml").write_text(text)
    result = CliRunner().invoke(main, ["watch", "--table", str(tmp / "b.watch.toml"),
                                       "--duration", "50ms"])
    assert result.exit_code == 2
    at = text.split("\n")[2].index('"') + 2 + len(BAD)
    assert f"b.watch.toml:3:{at}: error: {MESSAGE} [E410]" in result.stderr
    # on the command line: the words, the condition and a caret, as the debugger shows them
    result = CliRunner().invoke(main, ["watch", BAD, "--duration", "50ms"])
    assert result.exit_code == 2
    shown = result.stderr.split("\n")
    assert shown[0].endswith(f"error: watch condition: {MESSAGE}")
    assert shown[1:3] == [f"  {BAD}", "  " + " " * len(BAD) + "^"]
