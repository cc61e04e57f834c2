"""Helpers for the live board's tests: ``asictl serve`` as a real process, client
commands in process against its socket, and a fake server for hostile answers."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

from click.testing import CliRunner, Result

from asictl.cli import main
from asictl.host.live.protocol import LENGTH, socket_path

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"
#: Q 17.3 = I 4.0 or I 5.0: an output that follows inputs a command sets
OR_PROGRAM = """\
[SETUP]
4: iiii, 0
5: iiii, 0
17: oooo, 0

[PROGRAM]
        O   I 4.0
        O   I 5.0
        =   Q 17.3
        BE
[END]
"""


def cli(state: Path, *args: str) -> Result:
    result = CliRunner().invoke(main, [*args, "--state-dir", str(state)])
    assert "Traceback" not in result.output, result.output
    return result


def start_serve(
    state: Path, *extra: str, command: tuple[str, ...] = ("serve",),
    preexec_fn: Callable[[], None] | None = None,
) -> subprocess.Popen[str]:
    """``asictl serve`` (or ``command``) for ``state``, once it says it is live."""
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", *command, "--state-dir", str(state), *extra],
        stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
        preexec_fn=preexec_fn,
    )
    assert process.stderr is not None
    line = process.stderr.readline()
    assert "live at" in line, line
    return process


def stop(process: subprocess.Popen[str]) -> int:
    if process.poll() is None:
        process.send_signal(signal.SIGTERM)
        try:
            return process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
            raise
    return process.returncode


def wait_for(predicate: Callable[[], object], timeout: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.05)
    return False


def read_message(sock: socket.socket) -> bytes:
    """One length-prefixed message's bytes (b"" if the other end closed first)."""
    data = b""
    while len(data) < LENGTH.size:
        chunk = sock.recv(LENGTH.size - len(data))
        if not chunk:
            return b""
        data += chunk
    (length,) = LENGTH.unpack(data)
    body = b""
    while len(body) < length:
        chunk = sock.recv(length - len(body))
        if not chunk:
            return b""
        body += chunk
    return body


@contextmanager
def fake_server(
    state: Path, answer: Callable[[bytes], bytes], *, keep: bool = False
) -> Iterator[list[bytes]]:
    """A socket where the live board's belongs that answers a request with
    ``answer(request)`` and closes (with ``keep``: answers each request of a connection
    until the client closes); yields the requests it heard."""
    state.mkdir(mode=0o700, exist_ok=True)
    listener = socket.socket(socket.AF_UNIX)
    listener.bind(str(socket_path(state, 0x300)))
    listener.listen()
    heard: list[bytes] = []

    def serve() -> None:
        while True:
            try:
                conn, _ = listener.accept()
            except OSError:
                return
            with conn, suppress(OSError):
                while request := read_message(conn):
                    heard.append(request)
                    conn.sendall(answer(request))
                    if not keep:
                        break

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield heard
    finally:
        listener.shutdown(socket.SHUT_RDWR)
        listener.close()
        thread.join(5)
