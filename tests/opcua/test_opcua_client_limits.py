"""The OPC UA server's limits on its clients: connections and sessions are capped (1,000
anonymous sessions were accepted), a connection that never logs in is closed after the
login time-out (such connections stayed 30-60 s), and whatever OPC UA clients do, the
live board's own socket still answers its commands."""

from __future__ import annotations

import asyncio
import re
import socket
import time
from pathlib import Path
from urllib.parse import urlparse

import pytest
from asyncua import Client
from click.testing import CliRunner
from served_live import served_live

from asictl.cli import main


def served(state: Path, *limits: str):
    return served_live(
        state, ["serve", "--opcua", "127.0.0.1:0", *limits],
        r"OPC UA server for board 300h at (opc\.tcp://\S+)",
    )


def silent_connections(url: str, count: int) -> list[socket.socket]:
    where = urlparse(url)
    assert where.hostname is not None and where.port is not None
    return [socket.create_connection((where.hostname, where.port), timeout=5)
            for _ in range(count)]


def closed_within(sock: socket.socket, seconds: float) -> bool:
    sock.settimeout(seconds)
    try:
        return sock.recv(1) == b""
    except TimeoutError:
        return False
    except OSError:
        return True


def status(state: Path) -> int:
    result = CliRunner().invoke(main, ["status", "--state-dir", str(state)])
    return result.exit_code


@pytest.fixture
def state(tmp_path: Path) -> Path:
    tmp_path.chmod(0o700)
    return tmp_path


def test_connections_that_never_log_in_are_capped_and_closed(state: Path):
    with served(state, "--opcua-max-connections", "3", "--opcua-login-timeout", "1s") as url:
        silent = silent_connections(url, 3)
        time.sleep(0.3)
        [beyond] = silent_connections(url, 1)
        assert closed_within(beyond, 0.5), "a connection beyond the cap is closed at once"
        assert status(state) == 0, "the live board answers while OPC UA is full"
        started = time.monotonic()
        assert all(closed_within(sock, 5) for sock in silent)
        assert time.monotonic() - started < 3, "closed after the login time-out"
        for sock in [*silent, beyond]:
            sock.close()


def test_sessions_beyond_the_cap_are_refused_and_the_ones_in_use_go_on(state: Path):
    async def sessions(url: str) -> tuple[int, str]:
        clients = [Client(url, timeout=5) for _ in range(3)]
        for client in clients[:2]:
            await client.connect()
        try:
            await clients[2].connect()
        except Exception as exc:  # asyncua raises its status code as an exception
            refused = f"{type(exc).__name__}: {exc}"
        else:
            await clients[2].disconnect()
            refused = ""
        served_on = 0
        for client in clients[:2]:
            await client.nodes.server_state.read_value()
            served_on += 1
            await client.disconnect()
        return served_on, refused

    with served(state, "--opcua-max-sessions", "2") as url:
        served_on, refused = asyncio.run(sessions(url))
    assert served_on == 2
    assert re.search(r"BadMaxConnectionsReached", refused), refused


def test_the_limits_are_options_with_their_defaults_shown():
    text = " ".join(CliRunner().invoke(main, ["serve", "--help"]).output.split())
    for option, default in [("--opcua-max-connections", "32"), ("--opcua-max-sessions", "32"),
                            ("--opcua-login-timeout", "5s")]:
        assert re.search(rf"{option} .*?\[default: {default}[;\]]", text), option
