"""A board another process holds: commands say who holds it and stop, or wait with --wait.

The commands used to wait on the board's lock without a word while ``gateway serve``
held it (for as long as it served)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.cli import main
from asictl.host.emulated.boards import emulated_board, lock_file
from asictl.host.emulated.locking import LockBusy, exclusive, holder_file, note_holder, read_holder

#: Generous: a command that waits for the lock would run into it (a hang guard only).
HANG_GUARD_S = 60


def _asictl(*args: str, env: dict[str, str]) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "asictl", *args], stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True, env=env,
    )


def test_the_holder_is_recorded_beside_the_lock_and_removed_after(tmp_path: Path):
    lock = tmp_path / "x.lock"
    with exclusive(lock, "thing"):
        holder = read_holder(lock)
        assert holder is not None and holder.pid == os.getpid()
        note_holder(lock, "serving something")
        assert read_holder(lock).note == "serving something"  # type: ignore[union-attr]
        with pytest.raises(LockBusy) as busy, exclusive(lock, "thing"):
            pass
        assert f"thing is in use by process {os.getpid()} (" in str(busy.value)
        assert "serving something" in str(busy.value) and "--wait" in str(busy.value)
        assert busy.value.exit_code == 1
    assert not holder_file(lock).exists()
    with exclusive(lock, "thing"):  # free again
        pass


def test_a_stale_holder_file_is_replaced(tmp_path: Path):
    lock = tmp_path / "x.lock"
    holder_file(lock).write_text('{"pid": 1, "command": "killed", "since": 0}\n')
    with exclusive(lock, "thing"):
        assert read_holder(lock).pid == os.getpid()  # type: ignore[union-attr]


def test_a_holder_that_left_no_name_is_another_process(tmp_path: Path):
    lock = tmp_path / "x.lock"
    with exclusive(lock, "thing"):
        holder_file(lock).unlink()
        with pytest.raises(LockBusy, match="in use by another process"), exclusive(lock, "thing"):
            pass


@pytest.mark.parametrize(
    "command", [["status"], ["start"], ["stop"], ["reset"], ["upload", "-o", "x.asi"],
                ["download", "demos/blink.asi"]],
)
def test_every_board_command_stops_at_once_naming_the_holder(command, tmp_path: Path):
    root = Path(__file__).resolve().parents[2]
    args = [a if not a.startswith("demos/") else str(root / a) for a in command]
    with emulated_board(0x300, tmp_path):
        result = subprocess.run(
            [sys.executable, "-m", "asictl", *args, "--state-dir", str(tmp_path)],
            capture_output=True, text=True, timeout=HANG_GUARD_S, cwd=tmp_path,
        )
    assert result.returncode == 1, result.stderr
    assert f"board 300h is in use by process {os.getpid()}" in result.stderr
    assert "--wait" in result.stderr and "Traceback" not in result.stderr


def test_status_while_gateway_serve_holds_the_board(tmp_path: Path):
    """The gateway's board is live: status reaches it through its socket. Without the
    socket (removed while the server stands still: it would bind it again at once),
    status finds the lock held and names the holder at once."""
    env = {**os.environ, "ASICTL_STATE_DIR": str(tmp_path)}
    server = _asictl("gateway", "serve", "--tcp", "127.0.0.1:0", env=env)
    try:
        assert server.stderr is not None
        assert "serving tcp" in server.stderr.readline()
        live = subprocess.run(
            [sys.executable, "-m", "asictl", "status"], capture_output=True, text=True,
            env=env, timeout=HANG_GUARD_S,
        )
        assert live.returncode == 0 and "LPS" in live.stdout, live.stderr
        server.send_signal(signal.SIGSTOP)
        try:
            (tmp_path / "pc2-300h.sock").unlink()
            status = subprocess.run(
                [sys.executable, "-m", "asictl", "status"], capture_output=True, text=True,
                env=env, timeout=HANG_GUARD_S,
            )
        finally:
            server.send_signal(signal.SIGCONT)
        assert status.returncode == 1, status.stderr
        assert f"board 300h is in use by process {server.pid} (" in status.stderr
        assert "gateway serve --tcp 127.0.0.1:0" in status.stderr
        hint = re.search(r"--modbus (tcp://127\.0\.0\.1:\d+)", status.stderr)
        assert hint, status.stderr
        through = subprocess.run(
            [sys.executable, "-m", "asictl", "status", "--modbus", hint.group(1)],
            capture_output=True, text=True, env=env, timeout=HANG_GUARD_S,
        )
        assert through.returncode == 0, through.stderr
        assert "LPS" in through.stdout
        second = subprocess.run(
            [sys.executable, "-m", "asictl", "gateway", "serve", "--tcp", "127.0.0.1:0"],
            capture_output=True, text=True, env=env, timeout=HANG_GUARD_S,
        )
        assert (tmp_path / "pc2-300h.sock").is_socket()  # bound again once running
        assert second.returncode == 1, second.stderr
        assert f"already served live by asictl gateway serve (pid {server.pid})" in (
            second.stderr
        )
    finally:
        server.send_signal(signal.SIGINT)
        assert server.wait(timeout=HANG_GUARD_S) == 0
    assert not holder_file(lock_file(tmp_path, 0x300)).exists()


def test_wait_says_so_and_runs_once_the_board_is_free(tmp_path: Path):
    env = {**os.environ, "ASICTL_STATE_DIR": str(tmp_path)}
    release = threading.Event()
    held = threading.Event()

    def hold() -> None:
        with emulated_board(0x300, tmp_path):
            held.set()
            release.wait(HANG_GUARD_S)

    holder = threading.Thread(target=hold)
    holder.start()
    held.wait(HANG_GUARD_S)
    status = _asictl("status", "--wait", env=env)
    try:
        assert status.stderr is not None
        waiting = status.stderr.readline()
        assert f"board 300h is in use by process {os.getpid()}" in waiting
        assert waiting.rstrip().endswith("waiting for it (--wait)")
        assert status.poll() is None  # still waiting while the board is held
    finally:
        release.set()
        holder.join()
    out, _ = status.communicate(timeout=HANG_GUARD_S)
    assert status.returncode == 0 and "LPS" in out


def test_wait_excludes_modbus():
    result = CliRunner().invoke(main, ["status", "--modbus", "tcp://127.0.0.1:1", "--wait"])
    assert result.exit_code == 2 and "exclude each other" in result.output
