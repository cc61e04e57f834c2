"""``asictl force``, ``unforce`` and ``watch``: the bars under ``asictl serve`` with
demos/edge.asi, forces kept in the board's state between commands, and the refusals."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace

import pytest
from live_helpers import ROOT, cli, start_serve, stop

from asictl.errors import ExitCode
from asictl.host.forcing import NotForcing, force, unforce
from asictl.observe.operands import parse_assignment

EDGE = ROOT / "demos" / "edge.asi"


def status(state: Path) -> dict:
    result = cli(state, "status", "--json")
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


@pytest.fixture
def edge_served(tmp_path: Path) -> Iterator[Path]:
    state = tmp_path / "state"
    program = tmp_path / "edge.asi"
    shutil.copy(EDGE, program)
    (tmp_path / "edge.symbols.toml").write_text('Count = "FY 11"\nLamp = "Q 2.0"\n')
    process: subprocess.Popen[str] = start_serve(state)
    try:
        assert cli(state, "download", str(program), "--start").exit_code == 0
        assert cli(state, "bus", "match").exit_code == 0
        yield state
    finally:
        assert stop(process) == 0


def test_a_forced_flag_holds_against_the_program_and_is_listed(edge_served):
    """The issue's bar: edge.asi writes F 10.0 from I 1.0 (0) every cycle."""
    state = edge_served
    assert status(state)["control_state"] == "running"
    result = cli(state, "force", "F 10.0=1")
    assert result.exit_code == 0, result.output
    assert "FORCE 1: F 10.0 = 1" in result.stderr
    time.sleep(1)
    shown = status(state)
    assert shown["flags"][10] & 1 == 1
    assert shown["forced"] == [{"operand": "F 10.0", "value": 1, "symbol": None}]
    assert "forced   FORCE 1: F 10.0 = 1" in cli(state, "status").stdout
    listed = cli(state, "force", "--list")
    assert listed.exit_code == 0 and listed.stdout == "F 10.0 = 1\n"
    assert json.loads(cli(state, "force", "--list", "--json").stdout)["forced"][0][
        "operand"] == "F 10.0"
    assert cli(state, "unforce", "--all").exit_code == 0
    time.sleep(0.3)
    shown = status(state)
    assert shown["flags"][10] & 1 == 0 and shown["forced"] == []
    assert cli(state, "force", "--list").stdout == ""


def test_write_and_force_by_name_on_a_live_board(edge_served):
    state = edge_served
    assert cli(state, "write", "Count=7").exit_code == 0
    assert status(state)["flags"][11] == 7
    result = cli(state, "force", "Lamp=1")
    assert result.exit_code == 0 and result.stdout == "Q 2.0 (Lamp) = 1\n", result.output
    time.sleep(0.3)
    assert status(state)["slaves"]["2"]["outputs"] & 1 == 1  # the program writes 0
    assert cli(state, "unforce", "Lamp").exit_code == 0
    time.sleep(0.3)
    assert status(state)["slaves"]["2"]["outputs"] & 1 == 0


def test_forces_outlast_the_command_on_a_board_kept_in_its_state_file(tmp_path):
    state = tmp_path / "state"
    assert cli(state, "download", str(EDGE), "--start").exit_code == 0
    assert cli(state, "bus", "match").exit_code == 0
    assert cli(state, "force", "Q 2.1=1", "FY 12=0x55", "I 1.0=1").exit_code == 0
    shown = status(state)
    assert [f["operand"] for f in shown["forced"]] == ["I 1.0", "Q 2.1", "FY 12"]
    assert shown["flags"][12] == 0x55
    assert shown["flags"][10] & 1 == 1  # the program read the forced I 1.0
    assert shown["slaves"]["2"]["outputs"] & 0b0010  # the slave receives Q 2.1
    result = cli(state, "unforce", "FY 12", "I 1.0")
    assert result.exit_code == 0, result.output
    assert result.stdout == "Q 2.1 = 1\n"
    again = cli(state, "unforce", "FY 12")
    assert again.exit_code == 1 and "FY 12: not forced" in again.output
    assert "the others" not in again.output
    partly = cli(state, "unforce", "Q 2.1", "I 1.0", "F 12.3")  # only Q 2.1 is forced
    assert partly.exit_code == 1, partly.output
    assert "I 1.0, F 12.3: not forced (the others are released)" in partly.output
    assert status(state)["forced"] == []


def test_a_force_is_saved_before_it_is_acknowledged(tmp_path):
    """Killed right after ``force`` answered, the live board's state file has the force."""
    state = tmp_path / "state"
    process = start_serve(state)
    try:
        assert cli(state, "force", "FY 20=0x33").exit_code == 0
    finally:
        process.kill()
        process.wait(timeout=10)
    listed = cli(state, "force", "--list")
    assert listed.exit_code == 0 and listed.stdout == "FY 20 = 51\n"


@pytest.mark.parametrize(("args", "message"), [
    (("T 1=1",), "'T 1' cannot be forced"),
    (("Q 0.0=1",), "slaves 1..31"),
    (("F 10.0",), "expected OPERAND=VALUE"),
    (("FY 12=256",), "out of range"),
    (("Nothing=1",), "not an operand"),
])
def test_bad_forces_are_usage_errors_and_force_nothing(tmp_path, args, message):
    state = tmp_path / "state"
    result = cli(state, "force", *args)
    assert result.exit_code == 2 and message in result.output, result.output
    assert cli(state, "force", "--list").stdout == ""


def test_unforce_needs_operands_or_all(tmp_path):
    result = cli(tmp_path, "unforce")
    assert result.exit_code == 2 and "--all" in result.output


def test_a_master_without_a_force_list_is_refused_plainly():
    """A real PC2 board and a gateway reach ``force`` as masters without the emulated
    board's actions (``Master.action`` None): the refusal names the reason."""
    real = SimpleNamespace(name="300h", action=None)
    with pytest.raises(NotForcing, match="PC2 firmware has no force list") as caught:
        force(real, [parse_assignment("F 10.0=1")])  # type: ignore[arg-type]
    assert caught.value.exit_code == ExitCode.FAILED
    with pytest.raises(NotForcing):
        unforce(real, None)  # type: ignore[arg-type]


# --------------------------------------------------------------------------- watch


def _watcher(state: Path, *args: str) -> subprocess.Popen[str]:
    command = [sys.executable, "-m", "asictl", "watch", *args, "--state-dir", str(state)]
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": str(ROOT / "src")})


def test_watch_prints_json_lines(edge_served):
    """The issue's bar: ``watch "F 10.0" --format json --duration 2s``."""
    watcher = _watcher(edge_served, "F 10.0", "Count", "--format", "json", "--duration", "2s")
    out, err = watcher.communicate(timeout=60)
    assert watcher.returncode == 0, err
    assert [json.loads(line) for line in out.splitlines()] == [
        {"operand": "F 10.0", "symbol": None, "value": 0, "time": 0.0},
        {"operand": "FY 11", "symbol": "Count", "value": 0, "time": 0.0},
    ]


def test_watch_prints_a_line_for_each_change_until_ctrl_c(edge_served):
    state = edge_served
    watcher = _watcher(state, "F 10.0", "--format", "json", "--interval", "0.1s")
    assert watcher.stdout is not None
    first = json.loads(watcher.stdout.readline())  # the watch has begun
    assert first["value"] == 0
    assert cli(state, "force", "F 10.0=1").exit_code == 0
    change = json.loads(watcher.stdout.readline())
    watcher.send_signal(signal.SIGINT)
    out, err = watcher.communicate(timeout=30)
    assert watcher.returncode == 0, err
    assert change["operand"] == "F 10.0" and change["value"] == 1 and change["time"] > 0
    assert out == ""  # nothing changed since


def test_watch_stops_when_the_live_board_is_no_longer_served(tmp_path):
    state = tmp_path / "state"
    process = start_serve(state)
    try:
        watcher = _watcher(state, "F 10.0", "--interval", "0.1s")
        assert watcher.stdout is not None
        assert "F 10.0" in watcher.stdout.readline()  # the watch has begun
    finally:
        assert stop(process) == 0
    _, err = watcher.communicate(timeout=60)
    assert watcher.returncode == 1, err
    # between two reads, or (rarely) inside one, when the server closes the session
    assert "the live board is no longer served" in err or "went away" in err, err
    assert "Traceback" not in err


def test_watch_reads_a_table_and_shows_each_value_three_ways(tmp_path):
    state = tmp_path / "state"
    assert cli(state, "download", str(EDGE), "--start").exit_code == 0
    assert cli(state, "bus", "match").exit_code == 0
    assert cli(state, "force", "FY 12=0xA5").exit_code == 0
    table = tmp_path / "edge.watch.toml"
    table.write_text('watch = ["FY 12", "Q 2.0", "F 10.0"]\n')
    result = cli(state, "watch", "--table", str(table), "FY 12", "--duration", "0.5s")
    assert result.exit_code == 0, result.output
    rows = [line.split() for line in result.stdout.splitlines()]
    assert [row[1:] for row in rows] == [
        ["FY", "12", "165", "A5h", "10100101b"],
        ["Q", "2.0", "0", "0h", "0b"],
        ["F", "10.0", "0", "0h", "0b"],
    ]


@pytest.mark.parametrize(("text", "where", "message"), [
    ('watch = ["F 10.0",\n  oops ]\n', ":2:3: error: not valid TOML: invalid value [E400]",
     "oops ]"),
    ('# mine\nlist = ["F 10.0"]\n', ":2:1: error: unknown key 'list' (known: watch) [E407]",
     "list = "),
    ('watch = ["F 10.0", 3]\n', ":1:20: error: a watch table is one list", "watch = "),
])
def test_a_bad_watch_table_is_shown_at_its_line(tmp_path, text, where, message):
    table = tmp_path / "bad.watch.toml"
    table.write_text(text)
    result = cli(tmp_path / "state", "watch", "--table", str(table), "--duration", "1s")
    assert result.exit_code == 2
    assert f"{table}{where}" in result.stderr and message in result.stderr
    assert "^" in result.stderr and result.stdout == ""


@pytest.mark.parametrize(("args", "message"), [
    (("--duration", "1s"), "nothing to watch"),
    (("PSeg 0", "--duration", "1s"), "cannot be watched from the host"),
    (("F 10.0",), "give --duration"),
    (("F 10.0", "--interval", "soon"), "not a duration"),
])
def test_bad_watches_are_usage_errors(tmp_path, args, message):
    result = cli(tmp_path / "state", "watch", *args)
    assert result.exit_code == 2 and message in result.output, result.output


# --------------------------------------------------------------------------- hiflags


def test_hiflags_take_the_master_offline_and_back(edge_served):
    """The issue's bar: ``hiflags --offline`` shows in ``status --json``."""
    state = edge_served
    shown = cli(state, "hiflags")
    assert shown.stdout == "hi-flags 00h data exchange on, online, auto address on\n"
    result = cli(state, "hiflags", "--offline")
    assert result.exit_code == 0, result.output
    assert result.stdout == "hi-flags 02h data exchange on, offline, auto address on\n"
    time.sleep(0.3)
    status_now = status(state)
    assert status_now["hi_flags"] == 0x02 and status_now["phase"] == "offline"
    assert status_now["control_state"] != "running"
    both = cli(state, "hiflags", "--online", "--no-data-exchange", "--no-auto-address",
               "--json")
    assert json.loads(both.stdout) == {"hi_flags": 0x05, "offline": False,
                                       "data_exchange_active": False,
                                       "auto_address_enable": False}
    assert cli(state, "hiflags", "--data-exchange", "--auto-address").exit_code == 0
    time.sleep(0.3)
    status_now = status(state)
    assert status_now["hi_flags"] == 0 and status_now["control_state"] == "running"



@pytest.mark.parametrize("pair", [("--offline", "--online"),
                                  ("--data-exchange", "--no-data-exchange"),
                                  ("--no-auto-address", "--auto-address")])
def test_contradicting_hiflags_are_a_usage_error_and_change_nothing(tmp_path, pair):
    state = tmp_path / "state"
    result = cli(state, "hiflags", *pair, "--json")
    assert result.exit_code == 2, result.output
    assert "contradict each other: give one" in result.stderr
    assert all(f"{flag} " in result.stderr for flag in pair)
    assert result.stdout == ""  # refused before the board is opened
