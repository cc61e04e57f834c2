"""The Modbus transport against a gateway on loopback over one emulated master.

The bars: a download over Modbus uploads identically over the PC2 port of the same master
(and the reverse); time-outs and CRC errors are retried; failures are JobErrors.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from click.testing import CliRunner
from gateway_stub import stub_gateway

from asictl.board.board import Pc2Board
from asictl.board.images import VERSION_ID
from asictl.build import build_file
from asictl.cli import main
from asictl.gateway.server import background_gateway
from asictl.gateway.slave import GATEWAY_NAME, GatewaySlave
from asictl.host.emulated.boards import emulated_board
from asictl.host.transfer import Pc2Transport, StartMode, download, reset, set_start, upload
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.host.transports.gateway_pdus import (
    INFO_SOFTWARE,
    DownloadRequest,
    DownloadResponse,
    MasterInfoRequest,
    MasterInfoResponse,
    UploadRequest,
    UploadResponse,
)
from asictl.host.transports.jobs import JobError, JobStatus
from asictl.host.transports.modbus import open_modbus
from asictl.host.transports.target import parse_target
from asictl.platform.master import ControlFlag

ROOT = Path(__file__).resolve().parents[2]
DEMO = sorted((ROOT / "demos").glob("*.asi"))[0]


def pc2(board: Pc2Board) -> Pc2Transport:
    return Pc2Transport(Pc2Driver(EmulatedPort(board)))


def image_for(transport) -> object:
    result = build_file(str(DEMO), entry_points=transport.entry_points())
    assert result.image is not None
    return result.image


@pytest.mark.parametrize(
    ("pdu", "fields"),
    [
        (MasterInfoRequest(INFO_SOFTWARE), {"part": INFO_SOFTWARE}),
        (MasterInfoResponse("VAG-MOD", 1), {"text": "VAG-MOD"}),
        (DownloadRequest(0x1230, bytes(range(16))), {"address": 0x1230, "data": bytes(range(16))}),
        (DownloadResponse(address=0x10), {"address": 0x10}),
        (UploadRequest(address=0xFF00), {"address": 0xFF00}),
        (UploadResponse(0x20, bytes(range(16, 32))), {"address": 0x20}),
    ],
)
def test_pdus_round_trip_through_their_encoding(pdu, fields):
    data = pdu.encode()
    assert data[0] == len(data) - 1  # the byte count the RTU framer reads
    copy = type(pdu)()
    copy.decode(data)
    for name, value in fields.items():
        assert getattr(copy, name) == value


def test_telegrams_are_the_manuals():
    assert DownloadRequest(0x0102, bytes(16)).encode() == bytes([18, 1, 2]) + bytes(16)
    assert UploadRequest(address=0x0102).encode() == bytes([2, 1, 2])
    assert len(MasterInfoResponse("x", 1).encode()) == 34  # B = 33


@contextmanager
def serving(board: Pc2Board, kind: str) -> Iterator[str]:
    """The emulated gateway (``asictl.gateway.server``) or the pymodbus stub over ``board``.

    While it serves, the board belongs to the server's thread: tests touch it before and
    after only.
    """
    if kind == "stub":
        with stub_gateway(board) as url:
            yield url
        return
    with background_gateway(GatewaySlave(board)) as gateway:
        host, port = gateway.server.tcp_address
        yield f"tcp://{host}:{port}"


GATEWAYS = pytest.mark.parametrize("kind", ["gateway", "stub"])


@GATEWAYS
def test_download_over_modbus_uploads_identically_over_pc2(kind):
    board = Pc2Board()
    expected = pc2(board).entry_points()
    with serving(board, kind) as url, open_modbus(parse_target(url)) as modbus:
        assert modbus.entry_points() == expected
        image = image_for(modbus)
        download(modbus, image, start=StartMode.START)
    assert upload(pc2(board)).to_bytes() == image.to_bytes()
    assert board.control_flags & ControlFlag.START


@GATEWAYS
def test_download_over_pc2_uploads_identically_over_modbus(kind):
    board = Pc2Board()
    image = image_for(pc2(board))
    download(pc2(board), image, start=StartMode.STOP)
    with serving(board, kind) as url, open_modbus(parse_target(url)) as modbus:
        assert upload(modbus).to_bytes() == image.to_bytes()
        assert set_start(modbus, start=True) & ControlFlag.START
        assert not set_start(modbus, start=False) & ControlFlag.START
        reset(modbus)


@GATEWAYS
def test_a_reset_without_program_is_refused(kind):
    with (
        serving(Pc2Board(), kind) as url,
        open_modbus(parse_target(url)) as modbus,
        pytest.raises(JobError) as caught,
    ):
        reset(modbus)
    assert caught.value.status is JobStatus.EEPROM_ERROR


class DropFirst:
    """Lose (or corrupt) the first ``n`` responses of one function code."""

    def __init__(self, function: int, n: int, *, corrupt: bool = False, rtu: bool = False):
        self.function, self.left, self.corrupt, self.rtu = function, n, corrupt, rtu
        self.hits = 0

    def __call__(self, frame: bytes) -> bytes:
        code = frame[1] if self.rtu else frame[7]
        if code != self.function or not self.left:
            return frame
        self.left -= 1
        self.hits += 1
        return frame[:-1] + bytes([frame[-1] ^ 0xFF]) if self.corrupt else b""


def test_time_outs_are_retried():
    board, faults = Pc2Board(), DropFirst(67, 2)
    with stub_gateway(board, faults=faults) as url, open_modbus(
        parse_target(url), timeout=0.2, retries=2
    ) as modbus:
        assert modbus.entry_points() == pc2(board).entry_points()
    assert faults.hits == 2


def test_crc_errors_are_retried():
    board, faults = Pc2Board(), DropFirst(67, 2, corrupt=True, rtu=True)
    with stub_gateway(board, rtu=True, faults=faults) as url, open_modbus(
        parse_target(url), timeout=0.2, retries=2
    ) as modbus:
        assert modbus.entry_points() == pc2(board).entry_points()
    assert faults.hits == 2


def test_retries_are_bounded():
    faults = DropFirst(67, 100)
    started = time.monotonic()
    with stub_gateway(Pc2Board(), faults=faults) as url, open_modbus(
        parse_target(url), timeout=0.1, retries=1
    ) as modbus, pytest.raises(JobError) as caught:
        modbus.entry_points()
    assert caught.value.status is JobStatus.INTERFACE_ERROR
    assert "after 2 tries" in str(caught.value)
    assert faults.hits == 2
    assert time.monotonic() - started < 3


@pytest.mark.parametrize("spec", ["udp://host:502", "tcp://", "tcp://host:99999"])
def test_bad_urls_are_refused(spec):
    from asictl.errors import UserError

    with pytest.raises(UserError):
        parse_target(spec)


def test_serial_and_tcp_targets():
    target = parse_target("/dev/ttyUSB0", baud=19200, parity="even", stopbits=1)
    assert (target.device, target.baud, target.parity, target.stopbits) == (
        "/dev/ttyUSB0", 19200, "E", 1,
    )
    assert parse_target("tcp://gw").port == 502
    assert parse_target("rtu+tcp://gw:4001").rtu


def test_cli_download_over_modbus_then_upload_over_the_pc2_port(tmp_path):
    state = tmp_path / "state"
    runner = CliRunner()
    with emulated_board(0x300, state) as board, serving(board, "gateway") as url:
        result = runner.invoke(main, ["download", "--modbus", url, "--start", str(DEMO)])
        assert result.exit_code == 0, result.output
        status = runner.invoke(main, ["status", "--modbus", url, "--json"])
        assert status.exit_code == 0, status.output
        assert '"start_flag": true' in status.stdout
    out = tmp_path / DEMO.name
    result = runner.invoke(main, ["upload", "--port", "300h", "--state-dir", str(state),
                                  "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert out.read_text() == DEMO.read_text()


def test_cli_status_over_modbus_names_the_gateway_in_full():
    with serving(Pc2Board(), "gateway") as url:
        status = CliRunner().invoke(main, ["status", "--modbus", url, "--json"])
    assert status.exit_code == 0, status.output
    fields = json.loads(status.stdout)
    assert fields["master_name"].startswith(GATEWAY_NAME + " ")  # then the master's version
    assert fields["version_id"] == VERSION_ID.decode("ascii")


def test_cli_refuses_modbus_with_port_and_an_unreachable_gateway(tmp_path):
    runner = CliRunner()
    both = runner.invoke(main, ["stop", "--modbus", "tcp://127.0.0.1:1", "--port", "304h"])
    assert both.exit_code == 2 and "exclude each other" in both.output
    gone = runner.invoke(main, ["stop", "--modbus", "tcp://127.0.0.1:1", "--timeout", "100ms"])
    assert gone.exit_code == 1 and "Traceback" not in gone.output
    assert "127.0.0.1:1" in gone.output


def test_a_url_without_port_says_it_tried_502():
    gone = CliRunner().invoke(main, ["status", "--modbus", "tcp://127.0.0.1", "--timeout", "200ms"])
    assert gone.exit_code == 1, gone.output
    assert "cannot open the Modbus connection to tcp://127.0.0.1 (port 502, the Modbus/TCP " \
        "default" in gone.stderr
    given = CliRunner().invoke(main, ["status", "--modbus", "tcp://127.0.0.1:1"])
    assert given.exit_code == 1 and "port 502" not in given.stderr
