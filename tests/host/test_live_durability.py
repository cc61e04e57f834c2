"""What the live board acknowledged survives: a change of its non-volatile state is on
disk before the client hears it is done, so kill -9 right after ``download`` loses
nothing; a state folder removed under ``serve`` is made again (or, when another board
took its place meanwhile, left alone); a final save that fails says what is lost.
"""

from __future__ import annotations

import json
import resource
import shutil
import signal
import subprocess
from pathlib import Path

import pytest
from live_helpers import BLINK, ROOT, cli, start_serve, stop, wait_for

from asictl.host.live.protocol import socket_path

FIRST = ROOT / "demos" / "first.asi"


def _program(tmp_path: Path, n: int) -> Path:
    """A program of its own for round ``n``: the source (and so the EEPROM) says n."""
    path = tmp_path / f"round{n}.asi"
    path.write_text(FIRST.read_text().replace("; first.asi", f"; round {n} of first.asi", 1))
    return path


def _kill(process: subprocess.Popen[str]) -> None:
    process.send_signal(signal.SIGKILL)
    process.wait()


def _uploaded(state: Path) -> str:
    result = cli(state, "upload", "-o", "-")
    assert result.exit_code == 0, result.output
    return result.stdout


def _kill_after_download(tmp_path: Path, rounds: int) -> int:
    """Rounds whose acknowledged download was lost to a kill -9 right after it."""
    state, lost = tmp_path / "state", 0
    for n in range(rounds):
        process = start_serve(state)
        try:
            result = cli(state, "download", str(_program(tmp_path, n)))
        finally:
            _kill(process)
        assert result.exit_code == 0, result.output
        lost += f"; round {n} of first.asi" not in _uploaded(state)
    return lost


def test_no_acknowledged_download_is_lost_to_kill_9(tmp_path):
    """(Saved every 10 s, 15 of 30 such downloads were lost.)"""
    assert _kill_after_download(tmp_path, 5) == 0


@pytest.mark.slow
def test_no_acknowledged_download_is_lost_to_kill_9_in_100_rounds(tmp_path):
    assert _kill_after_download(tmp_path, 100) == 0


def test_a_stored_configuration_survives_kill_9(tmp_path):
    state = tmp_path / "state"
    process = start_serve(state)
    try:
        assert cli(state, "bus", "plug", "9", "7,F").exit_code == 0
        assert cli(state, "store", "configuration").exit_code == 0
        assert cli(state, "slave", "parameter", "9", "5").exit_code == 0
        assert cli(state, "store", "parameters").exit_code == 0
    finally:
        _kill(process)
    status = cli(state, "status", "--json")
    assert status.exit_code == 0, status.output
    slave = json.loads(status.stdout)["slaves"]["9"]
    assert slave["pp"] == 5 and slave["pcd"] == 0xF7 and "LPS" in slave["lists"], slave


# ------------------------------------------------------------------ the folder removed


def test_a_state_folder_removed_under_serve_is_made_again(tmp_path):
    state = tmp_path / "state"
    process = start_serve(state)
    try:
        assert cli(state, "download", str(BLINK)).exit_code == 0
        shutil.rmtree(state)
        assert wait_for(lambda: socket_path(state, 0x300).is_socket())
        assert (state / "pc2-300h.json").exists() and (state / "pc2-300h.lock").exists()
        assert "blink" in _uploaded(state)  # from the live board
        result = cli(state, "download", str(FIRST))
        assert result.exit_code == 0 and "new, empty one" not in result.stderr
        assert "created" not in result.stderr
    finally:
        assert stop(process) == 0
    assert process.stderr is not None
    log = process.stderr.read()
    assert f"the state directory {state} was removed while board 300h is served live" in log
    assert "first.asi" in _uploaded(state)  # one board: the live one, saved


def test_a_board_made_while_the_folder_was_gone_is_left_alone(tmp_path):
    """While the folder is gone (here while serve stands still) a command makes a new
    board there; serve then stops instead of overwriting it, its own state aside."""
    state = tmp_path / "state"
    process = start_serve(state)
    try:
        assert cli(state, "download", str(BLINK)).exit_code == 0
        process.send_signal(signal.SIGSTOP)
        shutil.rmtree(state)
        assert cli(state, "download", str(FIRST)).exit_code == 0  # a board of its own
        theirs = (state / "pc2-300h.json").read_text()
    finally:
        process.send_signal(signal.SIGCONT)
    assert process.wait(timeout=20) == 1
    assert process.stderr is not None
    log = process.stderr.read()
    assert "the live board stops and leaves it alone" in log, log
    assert (state / "pc2-300h.json").read_text() == theirs
    aside = list(state.glob("pc2-300h.live-*.json"))
    assert len(aside) == 1 and json.loads(aside[0].read_text())["eeprom"]
    assert "first.asi" in _uploaded(state)


# ------------------------------------------------------------------ saving fails


def test_a_save_that_fails_is_never_acknowledged_and_the_final_one_says_what_is_lost(
    tmp_path,
):
    """A file size limit (as a full disk does) lets the new board's state be written but
    not the program's: the download is not reported done, and neither is the stop."""
    state = tmp_path / "state"

    def small_files() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (700, 700))

    process = start_serve(state, preexec_fn=small_files)
    try:
        result = cli(state, "download", str(BLINK))
    finally:
        code = stop(process)
    assert result.exit_code == 1, result.output
    assert "the live board made the change but cannot save it" in result.stderr
    assert "downloaded" not in result.stderr
    assert code == 1
    assert process.stderr is not None
    log = process.stderr.read()
    assert "board 300h stopped, but its state could not be saved" in log
    assert "its last changes were NOT saved" in log
    assert "its state is saved" not in log
