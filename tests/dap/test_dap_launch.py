"""``asictl dap`` launched as an editor launches it, and driven over stdio.

The first test is the session an editor has with the adapter, request by request; the
others take one feature each: conditions, hit counts, stepping into and out of a block,
setting a value, the cycle step, a cycle time-out, the console, and bad requests.
"""

from __future__ import annotations

from collections.abc import Iterator
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


@pytest.fixture
def client(tmp_path: Path) -> Iterator[DapClient]:
    client = DapClient(tmp_path)
    yield client
    client.close()


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
