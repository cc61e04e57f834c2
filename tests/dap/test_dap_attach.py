"""``attach``: the adapter on the program of a live board served by ``asictl serve``.

The board runs in its own process, in real time; the adapter holds it for the session
(the master stands still while the program is paused) and lets it run on when the
editor disconnects.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner
from dap_client import DapClient

from asictl.cli import main
from asictl.errors import UserError
from asictl.host.live.client import open_live

ROOT = Path(__file__).resolve().parents[2]
PROGRAM = """\
[SETUP]
1: iiii, 0
2: oooo, 0
[PROGRAM]
        A   I 1.0
        S   F 0.0
***
        A   F 0.0
        =   Q 2.0
"""


def cli(state: Path, *args: str) -> str:
    result = CliRunner().invoke(main, [*args, "--state-dir", str(state)])
    assert result.exit_code == 0, result.output
    return result.stdout


@pytest.fixture
def served(tmp_path: Path) -> Iterator[tuple[Path, Path]]:
    """A live board running PROGRAM, its slaves plugged in: (state dir, program)."""
    state = tmp_path / "state"
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", "serve", "--state-dir", str(state)],
        stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(ROOT / "src")})
    assert process.stderr is not None
    assert "live at" in process.stderr.readline()
    program = tmp_path / "latch.asi"
    program.write_text(PROGRAM)
    (tmp_path / "latch.symbols.toml").write_text('Button = "I 1.0"\nLamp = "Q 2.0"\n')
    try:
        cli(state, "download", str(program), "--start")
        cli(state, "bus", "match")
        yield state, program
    finally:
        process.send_signal(signal.SIGTERM)
        try:
            assert process.wait(timeout=10) == 0
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
            raise


def attach(client: DapClient, state: Path, program: Path) -> None:
    """``client`` initialized and attached to the board served from ``state``."""
    client.request("initialize", {})
    client.request("attach", {"stateDir": str(state), "program": str(program)})
    client.wait_event("initialized")


def lamp(state: Path) -> int:
    status = json.loads(cli(state, "status", "--json"))
    return int(status["slaves"]["2"]["outputs"])


def master_ms(state: Path) -> float:
    client = open_live(state, 0x300)
    assert client is not None
    try:
        return float(client.action("view")["master_ms"])
    finally:
        client.close()


def test_attach_pause_inspect_set_step_and_let_it_run_on(served, tmp_path: Path):
    state, program = served
    client = DapClient(tmp_path)
    try:
        client.request("initialize", {"adapterID": "asictl"})
        client.request("attach", {"port": "300h", "stateDir": str(state),
                                  "program": str(program)})
        client.wait_event("initialized")
        [placed] = client.request("setBreakpoints", {
            "source": {"path": str(program)},
            "breakpoints": [{"line": 6, "condition": "Button == 0"}]})["breakpoints"]
        assert placed["verified"] and placed["line"] == 6
        client.request("configurationDone")
        stop = client.stopped()
        assert (stop["reason"], stop["file"], stop["line"]) == ("breakpoint", "latch.asi", 6)
        assert stop["frames"][0]["source"]["path"] == str(program.resolve())
        assert "attached to the live board 300h" in client.console()
        variables = client.variables()
        assert variables["Registers"]["RLO"] == "0"
        assert variables["Symbols"] == {"Button": "0", "Lamp": "0"}
        # the master stands still while the program is paused, and the program view waits
        first = master_ms(state)
        time.sleep(0.3)
        assert master_ms(state) == first
        watcher = open_live(state, 0x300)
        assert watcher is not None
        with pytest.raises(UserError, match="a debugger holds this board"):
            watcher.action("lines")
        watcher.close()
        frame = client.request("stackTrace", {"threadId": 1})["stackFrames"][0]["id"]
        scopes = {s["name"]: s["variablesReference"]
                  for s in client.request("scopes", {"frameId": frame})["scopes"]}
        client.request("setVariable", {"variablesReference": scopes["Symbols"],
                                       "name": "Button", "value": "1"})
        client.request("setBreakpoints", {"source": {"path": str(program)},
                                          "breakpoints": [{"line": 6}]})
        client.request("continue", {"threadId": 1})
        stop = client.stopped()  # the next cycle, which sees the input
        assert stop["line"] == 6
        assert client.variables()["Registers"]["RLO"] == "1"
        client.request("next", {"threadId": 1})
        assert client.stopped()["line"] == 8
        assert client.variables()["Flags"]["F 0.0"] == "1"
        client.request("setBreakpoints", {"source": {"path": str(program)}, "breakpoints": []})
        client.request("continue", {"threadId": 1})
        client.request("pause", {"threadId": 1})
        assert client.stopped()["reason"] == "pause"
        client.request("disconnect")
        assert client.process.wait(timeout=10) == 0
    finally:
        client.close()
    # detached: the program runs on in real time, and its lamp is on
    deadline = time.monotonic() + 5
    while lamp(state) != 1 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert lamp(state) == 1
    later = master_ms(state)
    time.sleep(0.2)
    assert master_ms(state) > later


def test_attach_without_the_program_names_by_the_boards_symbol_table(served, tmp_path: Path):
    """The download stored latch.symbols.toml with the program: an editor that attaches
    without the file at hand still gets the names."""
    state, _ = served
    client = DapClient(tmp_path)
    try:
        client.request("initialize", {"adapterID": "asictl"})
        client.request("attach", {"port": "300h", "stateDir": str(state)})
        client.wait_event("initialized")
        client.request("configurationDone")
        client.request("pause", {"threadId": 1})
        assert client.stopped()["reason"] == "pause"
        assert client.variables()["Symbols"] == {"Button": "0", "Lamp": "0"}
        client.request("disconnect")
        assert client.process.wait(timeout=10) == 0
    finally:
        client.close()


def test_attach_without_a_live_board_says_how_to_start_one(tmp_path: Path):
    client = DapClient(tmp_path)
    try:
        client.request("initialize", {})
        message = client.failing("attach", {"stateDir": str(tmp_path / "none")})
        assert "asictl serve --port 300h" in message
    finally:
        client.close()


def test_a_download_while_attached_ends_the_session(served, tmp_path: Path):
    state, program = served
    client = DapClient(tmp_path)
    try:
        attach(client, state, program)
        client.request("configurationDone")
        cli(state, "download", str(ROOT / "demos" / "blink.asi"), "--start")
        # the new [SETUP] may stop the old program first (its slaves are not the cable's):
        # that stop is shown, and going on from it ends the session
        event = client.events.get(timeout=60)
        while event["event"] not in ("stopped", "terminated"):
            event = client.events.get(timeout=60)
        if event["event"] == "stopped":
            assert event["body"]["text"] == "AS-i configuration error"
            client.request("continue", {"threadId": 1})
            client.wait_event("terminated")
        client.request("disconnect")
        assert client.process.wait(timeout=10) == 0
    finally:
        client.close()
    watcher = open_live(state, 0x300)  # nothing holds the board any more
    assert watcher is not None
    try:
        assert watcher.action("lines")["identity"]
    finally:
        watcher.close()


def test_a_cycle_time_out_on_the_live_board_stops_at_its_loop(served, tmp_path: Path):
    state, _ = served
    loop = tmp_path / "loop.asi"
    loop.write_text("[SETUP]\n1: iiii, 0\n[PROGRAM]\n    A   I 1.0\n    JC  = stuck\n"
                    "    BE\nstuck:\n    A   I 1.1\n    JU  = stuck\n")
    cli(state, "download", str(loop), "--start")
    cli(state, "bus", "match")
    client = DapClient(tmp_path)
    try:
        attach(client, state, loop)
        client.request("configurationDone")
        cli(state, "bus", "inputs", "I 1.0=1")  # into the endless loop
        stop = client.stopped()
        assert (stop["reason"], stop["line"]) == ("exception", 9)
        assert stop["text"].startswith("loop.asi:9: program cycle time-out")
        assert client.variables()["Inputs and outputs"]["I 1.0"] == "1"
    finally:
        client.close()


def test_a_board_halted_at_a_breakpoint_answers_reads_and_names_its_holder(served,
                                                                           tmp_path: Path):
    """status, the monitor's reading and an upload answer from the halted state; a change
    is refused with the debugger named, and happens neither now nor when it resumes."""
    state, program = served
    client = DapClient(tmp_path)
    try:
        attach(client, state, program)
        client.request("setBreakpoints", {"source": {"path": str(program)},
                                          "breakpoints": [{"line": 6}]})
        client.request("configurationDone")
        assert client.stopped()["line"] == 6
        held = f"halted at breakpoint line 6 by asictl dap (pid {client.process.pid})"
        result = CliRunner().invoke(main, ["status", "--state-dir", str(state)])
        assert result.exit_code == 0, result.output
        assert f"control  {held}\n" in result.stdout
        assert json.loads(cli(state, "status", "--json"))["held"] == held
        cli(state, "upload", "-o", str(tmp_path / "up.hex"))  # command 53, many times
        for change in (["stop"], ["write", "F 5.0=1"], ["force", "Q 2.1=1"],
                       ["bus", "inputs", "I 1.0=1"]):
            result = CliRunner().invoke(main, [*change, "--state-dir", str(state)])
            assert result.exit_code == 1, (change, result.output)
            assert f"the board is {held}" in result.stderr, (change, result.stderr)
        watcher = open_live(state, 0x300)
        assert watcher is not None
        changes, _ = watcher.changes(0)
        watcher.close()
        dap = f"asictl dap (pid {client.process.pid})"
        assert [(c.text, c.who) for c in changes][-1] == ("debugger attached", dap)
        client.request("setBreakpoints", {"source": {"path": str(program)},
                                          "breakpoints": []})
        client.request("continue", {"threadId": 1})  # answered before the board resumes
        deadline = time.monotonic() + 10
        status = json.loads(cli(state, "status", "--json"))
        while status["held"] is not None and time.monotonic() < deadline:
            time.sleep(0.05)
            status = json.loads(cli(state, "status", "--json"))
        assert status["held"] is None and status["control_state"] == "running"
        assert status["forced"] == [] and status["slaves"]["1"]["inputs"] == 0
    finally:
        client.close()
