"""Emulated boards kept in the state directory: shared between processes, locked, never
silently replaced when corrupt."""

from __future__ import annotations

import itertools
import json
import multiprocessing
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.board.asi import Slave
from asictl.cli import main
from asictl.errors import UserError
from asictl.host.emulated.boards import emulated_board, state_directory, state_file
from asictl.host.transports.ports import parse_port

ROOT = Path(__file__).resolve().parents[2]


def asictl(*args: str, state_dir: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "asictl", *args, "--state-dir", str(state_dir)],
        capture_output=True, text=True, cwd=state_dir,
    )


@pytest.mark.parametrize("text", ["300h", "0x300", "300", "300H", " 300h "])
def test_port_spellings(text: str):
    assert parse_port(text) == 0x300


@pytest.mark.parametrize("text", ["301h", "0x", "h", "768", "abc", "32Dh", ""])
def test_bad_ports_list_the_good_ones(text: str):
    with pytest.raises(UserError, match="300h, 304h, 308h, 30Ch, 320h, 324h, 328h, 32Ch"):
        parse_port(text)


def test_state_directory_precedence(monkeypatch: pytest.MonkeyPatch, tmp_path: Path):
    monkeypatch.delenv("ASICTL_STATE_DIR", raising=False)
    monkeypatch.delenv("XDG_STATE_HOME", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert state_directory() == tmp_path / "home" / ".local" / "state" / "asictl"
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "xdg"))
    assert state_directory() == tmp_path / "xdg" / "asictl"
    monkeypatch.setenv("ASICTL_STATE_DIR", str(tmp_path / "env"))
    assert state_directory() == tmp_path / "env"
    assert state_directory(tmp_path / "option") == tmp_path / "option"


def test_two_processes_in_turn_see_the_same_board(tmp_path: Path):
    down = asictl("download", str(ROOT / "demos" / "blink.asi"), "--start", state_dir=tmp_path)
    assert down.returncode == 0, down.stderr
    up = asictl("upload", "-o", "blink.asi", state_dir=tmp_path)
    assert up.returncode == 0, up.stderr
    assert (tmp_path / "blink.asi").read_bytes() == (ROOT / "demos" / "blink.asi").read_bytes()
    status = asictl("status", "--json", state_dir=tmp_path)
    assert json.loads(status.stdout)["start_flag"] is True
    other = asictl("status", "--json", "--port", "304h", state_dir=tmp_path)
    assert json.loads(other.stdout)["program"]["present"] is False, "each port is a board"


def hold_board(directory: str, name: str, log: str) -> None:
    """In a process of its own: use the board for a while (waiting for it, as --wait
    does) and note when."""
    with emulated_board(0x300, Path(directory), wait=True) as board:
        began = time.monotonic()
        board.bus.attach(Slave(len(board.bus) + 1, io_code=0, id_code=0, name=name))
        time.sleep(0.15)
        ended = time.monotonic()
    with open(log, "a") as out:
        out.write(f"{name} {began} {ended}\n")


def test_concurrent_commands_are_serialised_by_the_lock(tmp_path: Path):
    log = tmp_path / "log"
    context = multiprocessing.get_context("fork")
    workers = [
        context.Process(target=hold_board, args=(str(tmp_path), f"p{n}", str(log)))
        for n in range(4)
    ]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join(30)
        assert worker.exitcode == 0
    spans = sorted(
        (float(began), float(ended)) for _, began, ended in
        (line.split() for line in log.read_text().splitlines())
    )
    assert len(spans) == 4
    for (_, end), (begin, _) in itertools.pairwise(spans):
        assert end <= begin, "two processes used the board at the same time"
    with emulated_board(0x300, tmp_path) as board:
        assert sorted(s.name for s in board.bus) == ["p0", "p1", "p2", "p3"], "no save lost"


@pytest.mark.parametrize(
    "content",
    [b"{", b"\xff\xfe", b"[]", b'{"format": "something else"}', b""],
    ids=["truncated", "binary", "list", "foreign", "empty"],
)
def test_a_corrupt_state_is_reported_and_left_alone(tmp_path: Path, content: bytes):
    path = state_file(tmp_path, 0x300)
    path.write_bytes(content)
    before = os.stat(path)
    result = CliRunner().invoke(
        main, ["download", str(ROOT / "demos" / "blink.asi"), "--state-dir", str(tmp_path)]
    )
    assert result.exit_code == 2
    assert "pc2-300h.json" in result.stderr and "Traceback" not in result.output
    assert "left as it is" in result.stderr or "cannot read" in result.stderr
    assert path.read_bytes() == content
    assert os.stat(path).st_mtime_ns == before.st_mtime_ns


def test_the_state_is_saved_when_a_command_is_interrupted(tmp_path: Path):
    with pytest.raises(KeyboardInterrupt), emulated_board(0x300, tmp_path) as board:
        board.bus.attach(Slave(5, io_code=0, id_code=0))
        raise KeyboardInterrupt
    with emulated_board(0x300, tmp_path) as board:
        assert [s.address for s in board.bus] == [5]


def test_an_unusable_state_directory_is_a_clear_error(tmp_path: Path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(UserError, match="cannot use as state directory"), emulated_board(
        0x300, blocker / "sub"
    ):
        pass
