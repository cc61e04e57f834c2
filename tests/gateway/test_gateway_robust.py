"""The gateway survives its clients and its state directory.

Once, about 1,100 idle TCP connections exhausted the gateway's file descriptors: no other
client was served, asyncio printed a traceback per refused accept, and the next state
save failed and ended the gateway (exit 2); a failed save (the state directory removed)
ended it too. Now connections are limited (the one silent longest makes way for a new
one), silent ones time out, each condition is logged as one line (then at most once a
minute), and a failed save is logged and tried again while serving goes on.
"""

from __future__ import annotations

import re
import resource
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st
from pymodbus.client import ModbusTcpClient

from asictl.board.board import Pc2Board
from asictl.gateway.server import EVICT_AFTER_S, ConditionLog, background_gateway
from asictl.gateway.slave import GatewaySlave


def served(port: int) -> bool:
    """Whether a Modbus client gets an answer (register 1009, the control flags)."""
    client = ModbusTcpClient("127.0.0.1", port=port, timeout=3, retries=0)
    try:
        return client.connect() and not client.read_holding_registers(
            1009, count=1, device_id=1
        ).isError()
    except Exception:  # a closed connection, a time-out: not served
        return False
    finally:
        client.close()


class Gateway:
    """``asictl gateway serve`` in a subprocess, its stderr collected by a thread."""

    def __init__(self, process: subprocess.Popen[str]) -> None:
        self.process = process
        self.lines: list[str] = []
        first = process.stderr.readline() if process.stderr else ""
        self.lines.append(first)
        match = re.search(r"tcp 127\.0\.0\.1:(\d+)", first)
        assert match, first
        self.port = int(match.group(1))
        self._reader = threading.Thread(target=self._collect, daemon=True)
        self._reader.start()

    def _collect(self) -> None:
        assert self.process.stderr is not None
        for line in self.process.stderr:
            self.lines.append(line)

    def wait_for(self, text: str, timeout: float = 20) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if any(text in line for line in self.lines):
                return True
            time.sleep(0.05)
        return False

    def stop(self) -> int:
        self.process.send_signal(signal.SIGINT)
        code = self.process.wait(timeout=20)
        self._reader.join(5)
        return code


@contextmanager
def gateway_process(state: Path, *options: str, files: int | None = None) -> Iterator[Gateway]:
    def limit_files() -> None:
        if files is not None:
            resource.setrlimit(resource.RLIMIT_NOFILE, (files, files))

    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", "gateway", "serve", "--tcp", "127.0.0.1:0",
         "--state-dir", str(state), *options],
        stderr=subprocess.PIPE, text=True, preexec_fn=limit_files,
    )
    try:
        yield Gateway(process)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait(10)


def test_still_serving_after_400_idle_connections_under_ulimit_256(tmp_path):
    with gateway_process(tmp_path / "state", files=256) as gateway:
        idle = []
        try:
            for _ in range(400):
                idle.append(socket.create_connection(("127.0.0.1", gateway.port), timeout=5))
            time.sleep(EVICT_AFTER_S + 0.5)
            assert served(gateway.port)
            assert gateway.process.poll() is None
        finally:
            for connection in idle:
                connection.close()
        assert gateway.stop() == 0
    log = "".join(gateway.lines)
    assert "Traceback" not in log
    assert len(gateway.lines) <= 6, log  # started, one line per condition, stopped
    assert "(--max-connections)" in log


def test_still_serving_after_the_state_directory_is_removed_which_is_made_again(tmp_path):
    state = tmp_path / "state"
    with gateway_process(state, "--save-interval", "0.2") as gateway:
        assert served(gateway.port)
        shutil.rmtree(state)
        assert gateway.wait_for("was removed while board 300h is served live: made it again")
        assert (state / "pc2-300h.json").is_file() and (state / "pc2-300h.sock").is_socket()
        assert served(gateway.port)
        assert gateway.stop() == 0
    log = "".join(gateway.lines)
    assert "cannot save the board state" not in log, log
    assert (state / "pc2-300h.json").is_file()


# ----- in process: the limit, the eviction and the idle time-out ------------------------


def closed_by_peer(connection: socket.socket, within: float = 5.0) -> bool:
    connection.settimeout(within)
    try:
        return connection.recv(1) == b""
    except (TimeoutError, OSError):
        return False


def test_a_full_gateway_refuses_then_evicts_the_connection_silent_longest():
    lines: list[str] = []
    with background_gateway(GatewaySlave(Pc2Board()), max_connections=2, idle_timeout=None,
                            log=lines.append) as gateway:
        address = gateway.server.tcp_address
        oldest = socket.create_connection(address)
        newer = socket.create_connection(address)
        time.sleep(0.2)
        refused = socket.create_connection(address)
        assert closed_by_peer(refused)  # both still fresh: no room
        time.sleep(EVICT_AFTER_S + 0.2)
        assert served(address[1])  # takes the place of the oldest
        assert closed_by_peer(oldest)
        for connection in (oldest, newer, refused):
            connection.close()
    assert any("refusing further ones" in line for line in lines)
    assert any("closing the one silent longest" in line for line in lines)


def test_a_silent_connection_is_closed_after_the_idle_timeout():
    lines: list[str] = []
    with background_gateway(GatewaySlave(Pc2Board()), idle_timeout=0.3,
                            log=lines.append) as gateway:
        silent = socket.create_connection(gateway.server.tcp_address)
        assert closed_by_peer(silent)
        silent.close()
    assert lines == ["gateway: closing connections silent for 0.3 s (--idle-timeout)"]


# ----- property: one line per condition, then at most one a minute ---------------------


@given(st.lists(st.tuples(st.sampled_from("abc"), st.floats(0, 30)), max_size=200))
def test_condition_log_writes_a_line_per_condition_per_interval(events):
    now = [0.0]
    lines: list[str] = []
    log = ConditionLog(lines.append, interval=60.0, clock=lambda: now[0])
    for condition, step in events:
        now[0] += step
        log.event(condition, condition)
    for condition in "abc":
        times = [t for t, (c, _) in zip(_clock(events), events, strict=True) if c == condition]
        logged = [line for line in lines if line.startswith(condition)]
        if not times:
            assert logged == []
            continue
        assert logged[0] == condition  # the first event is logged at once
        assert len(logged) <= 1 + (times[-1] - times[0]) / 60.0
        # the counts of the later lines add up to the events they cover
        counted = sum(int(re.search(r"\((\d+) times", line).group(1)) for line in logged[1:])
        assert 1 + counted <= len(times)


def _clock(events: list[tuple[str, float]]) -> list[float]:
    now, times = 0.0, []
    for _, step in events:
        now += step
        times.append(now)
    return times
