"""``asictl dap`` launched as an editor launches it, and driven over stdio.

The first test is the session an editor has with the adapter, request by request; the
others take one feature each: conditions, hit counts, stepping into and out of a block,
setting a value, the cycle step, a cycle time-out, the console, and bad requests.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from dap_client import DapClient

ROOT = Path(__file__).resolve().parents[2]
DEMOS = ROOT / "demos"

#: A program of this test's own: a flag set from an input, a counter, a timer.
PROGRAM = """\
[SETUP]
1: iiii, 0
2: oooo, 0
[PROGRAM]
; the latch
        A   I 1.0
        S   F 0.0
        A   I 1.1
        R   F 0.0
***
        A   F 0.0
        =   Q 2.0
        L   KC 7
        S   C 0
        A   I 1.2
        CD  C 0
"""
LATCH_SET = 7  # S F 0.0
COMMENT = 5  # "; the latch"
SECOND_SEGMENT = 11  # A F 0.0


@pytest.fixture
def program(tmp_path: Path) -> Path:
    path = tmp_path / "latch.asi"
    path.write_text(PROGRAM)
    return path


def start(client: DapClient, breakpoints: dict[Path, list[dict[str, object]]] | None = None,
          **launch: object) -> dict[Path, list[dict[str, object]]]:
    """initialize, launch, initialized, setBreakpoints, configurationDone; the breakpoints
    the adapter answered with, per file."""
    capabilities = client.request("initialize", {"adapterID": "asictl", "linesStartAt1": True,
                                                 "columnsStartAt1": True})
    assert capabilities["supportsConfigurationDoneRequest"]
    client.request("launch", launch)
    client.wait_event("initialized")
    placed = {}
    for path, points in (breakpoints or {}).items():
        placed[path] = client.request("setBreakpoints", {
            "source": {"path": str(path)}, "breakpoints": points})["breakpoints"]
    client.request("configurationDone")
    return placed


def test_an_editor_session_breakpoint_variables_step_continue_end(client: DapClient,
                                                                  program: Path):
    placed = start(client, {program: [{"line": LATCH_SET}, {"line": COMMENT}]},
                   program=str(program), set=["I 1.0=1"])
    at_line, at_comment = placed[program]
    assert at_line["verified"] and at_line["line"] == LATCH_SET
    # the comment line has no code: the breakpoint moves to the next line that has
    assert at_comment["verified"] and at_comment["line"] == COMMENT + 1
    stop = client.stopped()
    assert stop["reason"] == "breakpoint" and stop["line"] == COMMENT + 1
    assert stop["hitBreakpointIds"] == [at_comment["id"]]
    assert stop["file"] == "latch.asi"
    assert stop["frames"][0]["source"]["path"] == str(program.resolve())
    client.request("continue", {"threadId": 1})
    stop = client.stopped()
    assert stop["reason"] == "breakpoint" and stop["line"] == LATCH_SET
    variables = client.variables()
    registers = variables["Registers"]
    assert registers["RLO"] == "1"  # A I 1.0 with the input set
    assert registers["ACCU1"] == "0 (0000h)"
    assert variables["Flags"]["F 0.0"] == "0"  # not yet set: the line has not run
    assert variables["Inputs and outputs"]["I 1.0"] == "1"
    client.request("next", {"threadId": 1})
    stop = client.stopped()
    assert stop["reason"] == "step" and stop["line"] == LATCH_SET + 1
    assert client.variables()["Flags"]["F 0.0"] == "1"
    client.request("setBreakpoints", {"source": {"path": str(program)}, "breakpoints": []})
    client.request("continue", {"threadId": 1})
    assert client.wait_event("exited")["exitCode"] == 0
    client.wait_event("terminated")
    client.request("disconnect")
    assert client.process.wait(timeout=10) == 0


def cycle_of(stop: dict[str, object]) -> int:
    """The program cycle a stop is in, from its frame's name (``latch.asi (cycle 3)``)."""
    frames = stop["frames"]
    assert isinstance(frames, list)
    name = frames[-1]["name"]
    return int(name.rpartition("cycle ")[2].rstrip(")"))


def test_conditions_compare_registers_and_operands(client: DapClient, program: Path,
                                                   tmp_path: Path):
    scenario = tmp_path / "latch.scenario.toml"
    scenario.write_text('[master]\ncycle_ms = 5\n[[step]]\nat_ms = 20\nset = { "I 1.0" = 1 }\n')
    placed = start(client, {program: [
        {"line": LATCH_SET, "condition": "RLO == 1"},
        {"line": SECOND_SEGMENT, "condition": "FY 0 > 0"},
        {"line": SECOND_SEGMENT + 1, "condition": "X 1 = 2"},
    ]}, program=str(program))
    assert [p["verified"] for p in placed[program]] == [True, True, False]
    assert "'X 1'" in placed[program][2]["message"]
    stop = client.stopped()
    assert (stop["line"], stop["reason"]) == (LATCH_SET, "breakpoint")
    assert cycle_of(stop) == 5  # cycles at 0, 5, 10, 15 ms saw I 1.0 = 0
    assert client.request("evaluate", {"expression": "I 1.0", "context": "hover"})[
        "result"] == "1"
    client.request("continue", {"threadId": 1})
    stop = client.stopped()  # F 0.0 is set now, so flag byte 0 is 1
    assert (stop["line"], cycle_of(stop)) == (SECOND_SEGMENT, 5)


def test_hit_counts(client: DapClient, program: Path):
    placed = start(client, {program: [{"line": SECOND_SEGMENT, "hitCondition": "3"},
                                      {"line": LATCH_SET, "hitCondition": "% 2"},
                                      {"line": LATCH_SET + 1, "hitCondition": "often"}]},
                   program=str(program), noScenario=True)
    assert [p["verified"] for p in placed[program]] == [True, True, False]
    stops = []
    for _ in range(4):
        stop = client.stopped()
        stops.append((stop["line"], cycle_of(stop)))
        client.request("continue", {"threadId": 1})
    # line 11 from its third hit on, line 7 at every second hit
    assert stops == [(LATCH_SET, 2), (SECOND_SEGMENT, 3), (LATCH_SET, 4), (SECOND_SEGMENT, 4)]


def test_step_into_and_out_of_a_function_block(client: DapClient):
    fb = DEMOS / "fb.asi"
    start(client, {fb: [{"line": 31}]}, program=str(fb), noScenario=True)
    assert client.stopped()["line"] == 31  # JU FB Latch
    client.request("stepIn", {"threadId": 1})
    stop = client.stopped()
    assert (stop["file"], stop["line"]) == ("latch.fb", 8)
    assert [(f["source"]["name"], f["line"]) for f in stop["frames"]] == [
        ("latch.fb", 8), ("fb.asi", 31)]
    assert stop["frames"][0]["source"]["path"] == str((DEMOS / "latch.fb").resolve())
    client.request("next", {"threadId": 1})
    assert client.stopped()["line"] == 9  # next inside the block stays in it
    client.request("stepOut", {"threadId": 1})
    stop = client.stopped()
    assert (stop["file"], stop["line"], len(stop["frames"])) == ("fb.asi", 33, 1)
    client.request("continue", {"threadId": 1})
    assert client.stopped()["line"] == 31
    client.request("next", {"threadId": 1})  # over the call
    assert client.stopped()["line"] == 33


def test_breakpoints_in_a_block_file(client: DapClient):
    fb = DEMOS / "fb.asi"
    block = DEMOS / "latch.fb"
    placed = start(client, {block: [{"line": 17}]}, program=str(fb), noScenario=True)
    assert placed[block][0]["verified"]
    stop = client.stopped()
    assert (stop["file"], stop["line"]) == ("latch.fb", 17)
    assert stop["frames"][1]["name"] == "fb.asi (cycle 1)"
    other = DEMOS / "count3.fb"  # part of the program, but it has code
    reply = client.request("setBreakpoints", {"source": {"path": str(ROOT / "README.md")},
                                              "breakpoints": [{"line": 1}]})
    assert not reply["breakpoints"][0]["verified"]
    assert other.exists()


def test_set_variable_writes_inputs_and_flags_only(client: DapClient, program: Path):
    start(client, {program: [{"line": LATCH_SET}]}, program=str(program), noScenario=True)
    client.stopped()
    frame = client.request("stackTrace", {"threadId": 1})["stackFrames"][0]["id"]
    scopes = {s["name"]: s["variablesReference"]
              for s in client.request("scopes", {"frameId": frame})["scopes"]}
    reply = client.request("setVariable", {"variablesReference": scopes["Inputs and outputs"],
                                           "name": "I 1.1", "value": "1"})
    assert reply["value"] == "1"
    assert "cannot be set" in client.failing("setVariable", {
        "variablesReference": scopes["Inputs and outputs"], "name": "Q 2.0", "value": "1"})
    assert "cannot be set" in client.failing("setVariable", {
        "variablesReference": scopes["Registers"], "name": "RLO", "value": "1"})
    assert "out of range" in client.failing("setVariable", {
        "variablesReference": scopes["Flags"], "name": "F 0.0", "value": "2"})
    client.request("setVariable", {"variablesReference": scopes["Flags"], "name": "F 0.0",
                                   "value": "1"})
    client.request("continue", {"threadId": 1})
    client.stopped()  # the next cycle sees what was written
    assert client.variables()["Inputs and outputs"]["I 1.1"] == "1"
    assert client.variables()["Flags"]["F 0.0"] == "1"  # as written: I 1.0 = 0 keeps it


def test_step_one_program_cycle(client: DapClient, program: Path):
    start(client, {program: [{"line": SECOND_SEGMENT}]}, program=str(program),
          noScenario=True)
    assert cycle_of(client.stopped()) == 1
    client.request("stepCycle", {"threadId": 1})
    stop = client.stopped()
    assert (stop["reason"], stop["line"], cycle_of(stop)) == ("step", 6, 2)


def test_a_cycle_time_out_stops_at_the_loop_line(client: DapClient, tmp_path: Path):
    loop = tmp_path / "loop.asi"
    loop.write_text("[SETUP]\n1: iiii, 0\n[PROGRAM]\n    A   I 1.0\n    JC  = stuck\n"
                    "    BE\nstuck:\n    A   I 1.1\n    JU  = stuck\n")
    start(client, program=str(loop), set=["I 1.0=1"], duration="50ms")
    stop = client.stopped()
    assert (stop["reason"], stop["line"]) == ("exception", 9)
    assert "program cycle time-out" in stop["text"]
    assert "program cycle time-out" in client.console()
    client.request("continue", {"threadId": 1})
    assert client.wait_event("exited")["exitCode"] == 1


def test_pause_and_the_console(client: DapClient, program: Path):
    start(client, program=str(program), duration="600s", set=["I 1.2=1"])
    client.request("pause", {"threadId": 1})
    stop = client.stopped()
    assert stop["reason"] == "pause" and stop["file"] == "latch.asi"
    printed = client.request("evaluate", {"expression": "print I 1.2, RLO",
                                          "context": "repl"})["result"]
    assert printed.splitlines()[0] == "I 1.2 = 1"
    assert client.request("evaluate", {"expression": "C 0", "context": "watch"})[
        "result"].endswith(")")
    assert "(the console also takes" in client.failing("evaluate", {"expression": "X 9"})
    client.request("continue", {"threadId": 1})
    assert "the program is running" in client.failing("next", {"threadId": 1})
    assert "the program is running" in client.failing("scopes", {"frameId": 1})


def test_a_failed_expectation_ends_with_exit_code_1(client: DapClient, program: Path,
                                                    tmp_path: Path):
    scenario = tmp_path / "latch.scenario.toml"
    scenario.write_text('[[step]]\nat_ms = 0\nset = { "I 1.0" = 1 }\n'
                        '[[step]]\nat_ms = 20\nexpect = { "Q 2.0" = 0 }\n')
    start(client, program=str(program))
    assert client.wait_event("exited")["exitCode"] == 1
    assert f"{scenario}:6: at 20 ms: Q 2.0 expected 0, got 1" in client.console()


def test_running_without_debugging_ignores_breakpoints(client: DapClient, program: Path):
    placed = start(client, {program: [{"line": LATCH_SET}]}, program=str(program),
                   noDebug=True, noScenario=True, duration="100ms")
    assert not placed[program][0]["verified"]
    assert client.wait_event("exited")["exitCode"] == 0


def test_stop_on_entry(client: DapClient, program: Path):
    start(client, program=str(program), stopOnEntry=True, noScenario=True)
    stop = client.stopped()
    assert (stop["reason"], stop["line"]) == ("entry", 6)


def test_an_image_is_debugged_in_the_source_it_carries(client: DapClient, tmp_path: Path):
    from click.testing import CliRunner

    from asictl.cli import main

    image = tmp_path / "blink.hex"
    result = CliRunner().invoke(main, ["compile", str(DEMOS / "blink.asi"), "-o", str(image)])
    assert result.exit_code == 0, result.output
    placed = start(client, {Path("blink.asi"): [{"line": 11}]}, program=str(image),
                   noScenario=True)
    assert placed[Path("blink.asi")][0]["verified"]
    stop = client.stopped()
    source = stop["frames"][0]["source"]
    assert "path" not in source and source["name"] == "blink.asi"
    content = client.request("source", {"source": source,
                                        "sourceReference": source["sourceReference"]})
    assert content["content"].splitlines()[10].strip().startswith("A   T 0")
    assert "no such source" in client.failing("source", {"sourceReference": 99})


@pytest.mark.parametrize(("key", "text", "says"), [
    ("program", "latch\0.asi", "NUL character"),
    ("program", "latch\ud800.asi", "no file name can have"),
    ("cwd", "here\0", "NUL character"),
    ("cwd", "\udfff", "no file name can have"),
])
def test_a_path_no_file_system_takes_is_a_request_error(client: DapClient, program: Path,
                                                         key: str, text: str, says: str):
    client.request("initialize", {"adapterID": "asictl"})
    arguments = {"program": str(program), key: text}
    message = client.failing("launch", arguments)
    assert f"'{key}' is not a path" in message and says in message
    assert "internal error" not in message
    client.request("launch", {"program": str(program)})  # the adapter is still there
