"""``serve --http`` and ``gateway serve --http`` as a user starts them: the options'
refusals, and the event stream hearing a change of the cable made by ``asictl bus
inputs`` from another process."""

from __future__ import annotations

import asyncio
import json
import os
import socket
import subprocess
import sys
import time
from contextlib import AbstractContextManager
from pathlib import Path

import httpx
import pytest
from click.testing import CliRunner
from served_live import served_live
from web_program import TOKEN, downloaded

from asictl.cli import main


def asictl(state: Path, *args: str) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "asictl", *args], capture_output=True, text=True, timeout=60,
        env={**os.environ, "ASICTL_STATE_DIR": str(state)},
    )
    assert result.returncode == 0, (args, result.stdout, result.stderr)


def served(
    state: Path, *command: str, env: dict[str, str] | None = None,
) -> AbstractContextManager[str]:
    """``asictl COMMAND... --http 127.0.0.1:0`` in its own process; yields the URL."""
    return served_live(state, [*command, "--http", "127.0.0.1:0"],
                       r"web page for board \S+ at (http://\S+)", env=env)


@pytest.mark.parametrize(("args", "env", "message"), [
    (["--http-writable"], {}, "--http-writable without --http HOST:PORT"),
    (["--http", "127.0.0.1:0", "--http-download"], {},
     "--http-download needs --http-writable (and its token)"),
    (["--http", "nowhere"], {}, "--http 'nowhere': expected HOST:PORT"),
    (["--http", "127.0.0.1:0", "--http-writable"], {},
     "--http-writable needs a token: --http-token-file FILE or $ASICTL_HTTP_TOKEN"),
    (["--http", "127.0.0.1:0", "--http-writable"], {"ASICTL_HTTP_TOKEN": "short"},
     "the HTTP token is 5 characters long"),
    (["--http", "127.0.0.1:0", "--http-token-file", "/nonexistent/token"], {},
     "--http-token-file /nonexistent/token: cannot read it"),
])
def test_bad_web_options_are_refused_before_anything_is_served(
    tmp_path: Path, args: list[str], env: dict[str, str], message: str,
):
    result = CliRunner().invoke(main, ["serve", "--state-dir", str(tmp_path), *args], env=env)
    assert result.exit_code == 2
    assert message in result.output
    assert "Traceback" not in result.output
    assert not list(tmp_path.glob("*.sock"))


def test_the_event_stream_hears_an_input_changed_by_another_command(tmp_path: Path):
    state = downloaded(tmp_path)
    with served(state, "serve") as url, httpx.Client(base_url=url, timeout=20) as web:
        assert web.get("/api/status").json()["phase"] == "normal operation"
        seen: list[int] = []
        with web.stream("GET", "/api/events", params={"watch": ["Lamp", "Nobody"]}) as events:
            for line in events.iter_lines():
                if not line.startswith("data: "):
                    continue
                data = json.loads(line[len("data: "):])
                lamp, nobody = data["watch"]
                assert nobody["exit"] == 2 and "'Nobody'" in nobody["error"]
                seen.append(lamp["value"])
                if len(seen) == 1:
                    asictl(state, "bus", "inputs", "Start=1")
                if lamp["value"] == 1:
                    break
        assert seen[0] == 0 and seen[-1] == 1
        refused = web.post("/api/force", json={"assignments": ["Start=0"]})
        assert refused.status_code == 403 and refused.json()["exit"] == 1


def test_gateway_serve_has_the_page_too_and_takes_writes_with_the_token(tmp_path: Path):
    state = downloaded(tmp_path)
    token = tmp_path / "token"
    token.write_text(TOKEN + "\n")
    command = ("gateway", "serve", "--tcp", "127.0.0.1:0", "--http-writable",
               "--http-token-file", str(token))
    with served(state, *command) as url, httpx.Client(base_url=url, timeout=20) as web:
        assert web.get("/").text.lower().startswith("<!doctype html>")
        bearer = {"Authorization": f"Bearer {TOKEN}"}
        forced = web.post("/api/force", json={"assignments": ["Answer=7"]}, headers=bearer)
        assert forced.json() == {"forced": [{"operand": "FY 12", "value": 7,
                                             "symbol": "Answer"}]}
        assert web.get("/api/operands/FY 12").json()["value"] == 7


def test_clients_that_never_read_hold_up_neither_the_board_nor_other_clients(tmp_path: Path):
    state = downloaded(tmp_path)
    env = {"ASICTL_HTTP_TOKEN": TOKEN}
    bearer = {"Authorization": f"Bearer {TOKEN}"}
    with served(state, "serve", "--http-writable", env=env) as url, \
            httpx.Client(base_url=url, timeout=20) as web:
        host, port = url.removeprefix("http://").rstrip("/").rsplit(":", 1)
        silent = []
        for _ in range(20):  # each asks for the stream, then never reads a byte of it
            hostile = socket.create_connection((host, int(port)))
            hostile.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1024)
            hostile.sendall(b"GET /api/events?watch=FY%2020 HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
            silent.append(hostile)
        try:
            started = time.monotonic()
            for value in range(100):  # a change at every write: a reading for every listener
                written = web.post("/api/write", json={"assignments": [f"FY 20={value}"]},
                                   headers=bearer)
                assert written.status_code == 200
            took = time.monotonic() - started
            assert web.get("/api/operands/FY 20").json()["value"] == 99
            asictl(state, "status")  # the board's own socket answers meanwhile
        finally:
            for hostile in silent:
                hostile.close()
        assert took < 30, took


def test_a_listener_keeps_only_the_newest_reading():
    from asictl.web.stream import Listener, Reading

    listener = Listener()
    readings = [Reading(None, str(n), float(n)) for n in range(1000)]  # type: ignore[arg-type]
    for reading in readings:
        listener.offer(reading)
    assert listener.latest is readings[-1]
    assert asyncio.run(listener.next(1.0)) is readings[-1]
    assert asyncio.run(listener.next(0.01)) is None
