"""The live board: ``asictl serve`` as a real process, and its protocol in process.

The serve tests start ``python -m asictl serve`` with a temporary state directory and
stop it (SIGTERM, then SIGKILL) however the test ends; client commands run in process
against its socket, as any asictl command would.
"""

from __future__ import annotations

import json
import socket
import stat
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import Result
from live_helpers import BLINK, OR_PROGRAM, cli, start_serve, stop, wait_for

from asictl.board.board import Pc2Board
from asictl.host.live.client import LiveClient, LivePort, open_live
from asictl.host.live.protocol import encode, socket_path
from asictl.host.live.server import background_live
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.platform.pc2 import PROGRAM_BUFFER, Command


class Served:
    def __init__(self, state: Path, process: subprocess.Popen[str]) -> None:
        self.state, self.process = state, process

    def __call__(self, *args: str) -> Result:
        return cli(self.state, *args)

    def status(self) -> dict:
        result = self("status", "--json")
        assert result.exit_code == 0, result.output
        return json.loads(result.stdout)


@pytest.fixture
def served(tmp_path: Path) -> Iterator[Served]:
    state = tmp_path / "state"
    process = start_serve(state)
    try:
        yield Served(state, process)
    finally:
        assert stop(process) == 0


# --------------------------------------------------------------------------- the bars


def test_an_input_reaches_a_running_program_through_the_live_board(served, tmp_path):
    program = tmp_path / "or.asi"
    program.write_text(OR_PROGRAM)
    assert served("download", str(BLINK), "--start").exit_code == 0
    result = served("download", str(program), "--start")
    assert result.exit_code == 0, result.output
    assert "asictl bus match" in result.stderr, "the config error names the fix"
    assert served("bus", "match").exit_code == 0
    assert served("bus", "inputs", "4", "0b0001").exit_code == 0
    assert wait_for(lambda: served.status()["slaves"]["17"]["outputs"] == 8)
    assert served("bus", "inputs", "I 4.0=0").exit_code == 0
    assert wait_for(lambda: served.status()["slaves"]["17"]["outputs"] == 0)
    assert served("bus", "inputs", "5", "1").exit_code == 0
    assert wait_for(lambda: served.status()["slaves"]["17"]["outputs"] == 8)


def test_a_blinker_blinks_in_wall_time(served):
    """Time runs between commands: samples over 1.8 s see the 500 ms blinker both ways."""
    assert served("download", str(BLINK), "--start").exit_code == 0
    seen = set()
    start = time.monotonic()
    while time.monotonic() - start < 1.8:
        seen.add(served.status()["slaves"]["31"]["outputs"] & 1)
        time.sleep(0.1)
    assert seen == {0, 1}


def test_a_refused_address_change_reports_83a1(served):
    result = served("slave", "address", "9", "10")
    assert result.exit_code == 1
    assert "83A1" in result.stderr and "no slave at the old address" in result.stderr


def test_the_state_is_saved_when_serving_ends(tmp_path):
    state = tmp_path / "state"
    process = start_serve(state)
    try:
        assert cli(state, "download", str(BLINK)).exit_code == 0
    finally:
        assert stop(process) == 0
    assert not socket_path(state, 0x300).exists(), "the socket goes with the server"
    saved = json.loads((state / "pc2-300h.json").read_text())
    assert saved["eeprom"].startswith("41")  # the image's magic survived, as on the board
    result = cli(state, "upload", "-o", str(tmp_path / "back.asi"))
    assert result.exit_code == 0, result.output
    assert (tmp_path / "back.asi").read_text() == BLINK.read_text()


def test_a_second_server_is_refused_and_says_who_serves(served):
    other = subprocess.run(
        [sys.executable, "-m", "asictl", "serve", "--state-dir", str(served.state)],
        capture_output=True, text=True, timeout=30,
    )
    assert other.returncode == 1
    assert "already served live by asictl serve (pid" in other.stderr


def test_the_socket_is_the_owners_only(served):
    mode = socket_path(served.state, 0x300).stat().st_mode
    assert stat.S_ISSOCK(mode) and stat.S_IMODE(mode) == 0o600


def test_two_clients_at_once_both_work(served, tmp_path):
    """A monitor-like reader hammers status while downloads run: nothing fails, the
    last download is what the master holds."""
    errors: list[str] = []
    done = threading.Event()

    def reader() -> None:
        while not done.is_set():
            result = served("status", "--json")
            if result.exit_code != 0:
                errors.append(result.output)

    thread = threading.Thread(target=reader)
    thread.start()
    try:
        for _ in range(3):
            result = served("download", str(BLINK), "--start")
            assert result.exit_code == 0, result.output
    finally:
        done.set()
        thread.join(30)
    assert errors == []
    verify = served("verify", str(BLINK))
    assert verify.exit_code == 0 and "identical" in verify.stdout


def test_gateway_serve_is_a_live_board_too(tmp_path):
    state = tmp_path / "state"
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", "gateway", "serve", "--tcp", "127.0.0.1:0",
         "--state-dir", str(state)],
        stderr=subprocess.PIPE, text=True,
    )
    try:
        assert process.stderr is not None
        line = process.stderr.readline()
        assert "the board is live at" in line, line
        assert cli(state, "download", str(BLINK), "--start").exit_code == 0
        status = json.loads(cli(state, "status", "--json").stdout)
        assert status["control_state"] == "running"
        assert socket_path(state, 0x300).exists()
    finally:
        assert stop(process) == 0


# --------------------------------------------------------------------------- in process


@pytest.fixture
def live(tmp_path: Path) -> Iterator[Path]:
    with background_live(0x300, tmp_path, identity={"command": "test"}):
        yield tmp_path


def test_the_driver_over_the_socket_reads_what_it_wrote(live):
    client = open_live(live, 0x300)
    assert client is not None and client.server["command"] == "test"
    driver = Pc2Driver(LivePort(client))
    data = bytes(range(200, 256)) + bytes(range(184))
    driver.write(PROGRAM_BUFFER, data[:240])
    assert driver.read(PROGRAM_BUFFER, 240) == data[:240]
    assert driver.command(Command.GET_STATUS) is not None
    client.close()


def test_each_connection_keeps_its_own_pointer(live):
    a, b = open_live(live, 0x300), open_live(live, 0x300)
    assert a is not None and b is not None
    port_a, port_b = LivePort(a), LivePort(b)
    Pc2Driver(port_a).write(0x200, b"\x11\x22")
    port_a.write(1, 0x00)  # a points at 200h ...
    port_a.write(2, 0x02)
    port_a.flush()
    Pc2Driver(port_b).read(0x0F0, 8)  # ... b moves the board's pointer elsewhere
    assert port_a.read(0) == 0x11 and port_a.read(0) == 0x22
    a.close()
    b.close()


def test_a_connections_pointer_moves_as_the_boards_own_across_requests(live):
    """Reading on past byte 255 of a page continues at 000h (manual 7.2), also when the
    reads come in two requests with another client's between."""
    a, b = open_live(live, 0x300), open_live(live, 0x300)
    assert a is not None and b is not None
    first = Pc2Driver(LivePort(b)).read(0x000, 2)
    port = LivePort(a)
    port.write(1, 0xFE)  # a points at 2FEh
    port.write(2, 0x02)
    port.read(0)
    port.read(0)  # 2FFh: the board's pointer wraps to 000h
    Pc2Driver(LivePort(b)).read(0x1F0, 4)
    assert [port.read(0), port.read(0)] == list(first)
    a.close()
    b.close()


def test_a_waiting_session_is_announced(live):
    a, b = open_live(live, 0x300), open_live(live, 0x300)
    assert a is not None and b is not None
    heard: list[str] = []
    with a.session("first holder"):
        def second() -> None:
            with b.session("second", heard.append):
                pass

        thread = threading.Thread(target=second)
        thread.start()
        assert wait_for(lambda: heard == ["first holder (a session silent for 10 s is ended)"])
    thread.join(5)
    assert not thread.is_alive()
    a.close()
    b.close()


def test_bad_requests_are_answered_not_fatal(live):
    client = open_live(live, 0x300)
    assert client is not None
    for request in ({"op": "nonsense"}, {"op": "io", "ops": [["w", 7, [1]]]},
                    {"op": "io", "ops": [["w", 0, [300]]]}, {"op": "action", "name": "x"}):
        with pytest.raises(Exception) as caught:
            client.request(request)
        assert "Traceback" not in str(caught.value)
    raw = socket.socket(socket.AF_UNIX)
    raw.connect(str(socket_path(live, 0x300)))
    raw.sendall(encode({"op": "hello"})[:3])  # a broken message: the server drops it
    raw.close()
    assert client.hello()["command"] == "test", "the server still answers"
    client.close()


def test_a_stale_socket_is_removed(tmp_path):
    path = socket_path(tmp_path, 0x300)
    stale = socket.socket(socket.AF_UNIX)
    stale.bind(str(path))
    stale.close()  # the file stays, nobody listens
    assert open_live(tmp_path, 0x300) is None
    assert not path.exists()
    result = cli(tmp_path, "status")
    assert result.exit_code == 0 and "new, empty one was created" in result.stderr


def test_live_client_is_a_plain_client(live):
    """A LiveClient's requests and a local EmulatedPort give one board the same bytes."""
    board = Pc2Board()
    board.advance(100)
    local = Pc2Driver(EmulatedPort(board)).read(0x0B0, 48)
    client = open_live(live, 0x300)
    assert isinstance(client, LiveClient)
    assert Pc2Driver(LivePort(client)).read(0x0B0, 48) == local
    client.close()


def test_commissioning_on_a_live_board_keeps_volatile_state(served):
    """Between two commands the live board keeps what only lives in RAM (the PI)."""
    assert served("bus", "plug", "9", "7,F").exit_code == 0
    assert served("store", "configuration").exit_code == 0
    assert served("slave", "parameter", "9", "5").stdout.strip() == "5h"
    assert served("store", "parameters").exit_code == 0
    assert served.status()["slaves"]["9"]["pp"] == 5
    assert served("bus", "show", "--io", "devport").exit_code == 2
    assert served("write", "FY 10=0x12", "F 11.3=1").exit_code == 0
    assert served.status()["flags"][10:12] == [0x12, 0x08]
    assert served("write", "Q 9=0b0101", "Q 9.3=1").exit_code == 0
    assert served.status()["slaves"]["9"]["outputs"] == 0b1101


def test_write_takes_every_operand_form_and_value_form(served):
    """``asictl write`` reads OPERAND=VALUE as scenarios and the debugger do
    (observe.operands): bits, bytes, a slave's four outputs, two slaves' byte; values in
    decimal, 0x, 0b and the IL's 0Ah; the assignments apply in order."""
    for address in ("20", "21"):
        assert served("bus", "plug", address, "oooo,0").exit_code == 0
    result = served("write", "QB 20=0x5A", "Q 21.3=0", "F 10.0=1", "FY 11=0Ah", "F 10.7=1",
                    "FY 12=0b1000_0001", "FY 12=12d")
    assert result.exit_code == 0, result.output
    status = served.status()
    assert (status["slaves"]["20"]["outputs"], status["slaves"]["21"]["outputs"]) == (0xA, 0x5)
    assert status["flags"][10:13] == [0x81, 0x0A, 12]
