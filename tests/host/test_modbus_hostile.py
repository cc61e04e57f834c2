"""A gateway that answers wrongly never crashes the Modbus client (exit 3).

A gateway that reset the connection, or answered with fewer registers than asked, once
ended ``asictl status --modbus`` with an internal error. Any malformed or short answer,
and any connection lost mid-request, is now a ``JobError`` with STATUS 8383h
(INTERFACE_ERROR): exit 1 on the command line. The fuzz test puts a proxy between the
client and the emulated gateway that mangles the answers by a drawn plan: passed on,
cut short, shortened inside a correct frame, a byte changed, replaced by garbage,
the connection closed or reset.
"""

from __future__ import annotations

import socket
import struct
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from time_limit import no_hang

from asictl.board.board import Pc2Board
from asictl.build import build_file
from asictl.cli import main
from asictl.errors import UserError
from asictl.gateway.server import background_gateway
from asictl.gateway.slave import GatewaySlave
from asictl.host.modbus_master import read_status
from asictl.host.transfer import Pc2Transport, StartMode, download, set_start, upload
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.host.transports.jobs import JobError, JobStatus
from asictl.host.transports.modbus import open_modbus
from asictl.host.transports.target import parse_target

DEMO = sorted((Path(__file__).resolve().parents[2] / "demos").glob("*.asi"))[0]

#: ("pass",) ("cut", n) ("short", n) ("fewer", n) ("flip", i, v) ("garbage", b) ("close",)
#: ("reset",)
Mangle = tuple


def _read_frame(sock: socket.socket) -> bytes | None:
    """One Modbus/TCP frame (MBAP header and PDU), or None when the peer has gone."""
    header = _read_exactly(sock, 7)
    if header is None:
        return None
    length = struct.unpack(">H", header[4:6])[0]
    body = _read_exactly(sock, length - 1)
    return None if body is None else header + body


def _read_exactly(sock: socket.socket, size: int) -> bytes | None:
    data = b""
    while len(data) < size:
        try:
            chunk = sock.recv(size - len(data))
        except OSError:
            return None
        if not chunk:
            return None
        data += chunk
    return data


def _apply(mangle: Mangle, frame: bytes, client: socket.socket) -> bool:
    """Send ``frame`` as ``mangle`` says; False when the connection is gone after it."""
    match mangle:
        case ("pass",):
            client.sendall(frame)
        case ("cut", n):
            client.sendall(frame[: n % len(frame)])
        case ("short", n):  # a well-framed answer with its last n bytes missing
            pdu = frame[7 : max(8, len(frame) - n)]
            client.sendall(frame[:4] + struct.pack(">H", len(pdu) + 1) + frame[6:7] + pdu)
        case ("fewer", n):  # a read answer with n registers fewer, byte count to match
            pdu = frame[7:]
            if pdu[0] == 3:
                kept = pdu[2 : max(2, len(pdu) - 2 * n)]
                pdu = bytes([3, len(kept)]) + kept
            client.sendall(frame[:4] + struct.pack(">H", len(pdu) + 1) + frame[6:7] + pdu)
        case ("flip", i, v):
            changed = bytearray(frame)
            changed[i % len(frame)] = v
            client.sendall(bytes(changed))
        case ("garbage", data):
            client.sendall(data)
        case ("close",):
            client.close()
            return False
        case ("reset",):
            client.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
            client.close()
            return False
    return True


@contextmanager
def mangling_proxy(upstream: tuple[str, int], plan: Sequence[Mangle]) -> Iterator[str]:
    """A Modbus/TCP proxy on loopback whose k-th answer is sent as ``plan[k]`` says (and
    every answer after the plan as it is); yields the ``--modbus`` URL."""
    listener = socket.create_server(("127.0.0.1", 0))
    listener.settimeout(0.2)
    done = threading.Event()

    def serve_one(client: socket.socket) -> None:
        with socket.create_connection(upstream) as gateway, client:
            answers = 0
            while not done.is_set():
                request = _read_frame(client)
                if request is None:
                    return
                gateway.sendall(request)
                answer = _read_frame(gateway)
                if answer is None:
                    return
                mangle = plan[answers] if answers < len(plan) else ("pass",)
                answers += 1
                if not _apply(mangle, answer, client):
                    return

    def accept() -> None:
        while not done.is_set():
            try:
                client, _ = listener.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            threading.Thread(target=serve_one, args=(client,), daemon=True).start()

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{listener.getsockname()[1]}"
    finally:
        done.set()
        thread.join(5)
        listener.close()


@pytest.fixture(scope="module")
def gateway_address() -> Iterator[tuple[str, int]]:
    """The emulated gateway in front of a master holding a program (so uploads read one)."""
    board = Pc2Board()
    transport = Pc2Transport(Pc2Driver(EmulatedPort(board)))
    prepared = build_file(str(DEMO), entry_points=transport.entry_points())
    assert prepared.image is not None
    download(transport, prepared.image, start=StartMode.STOP)
    with background_gateway(GatewaySlave(board)) as gateway:
        assert gateway.server.tcp_address is not None
        yield gateway.server.tcp_address


def test_a_connection_reset_mid_request_is_an_interface_error(gateway_address):
    with mangling_proxy(gateway_address, [("pass",), ("reset",)]) as url, open_modbus(
        parse_target(url), timeout=0.2, retries=0
    ) as modbus, pytest.raises(JobError) as caught:
        read_status(modbus)
    assert caught.value.status is JobStatus.INTERFACE_ERROR
    assert "connection to the gateway" in str(caught.value)


def test_fewer_registers_than_asked_is_an_interface_error(gateway_address):
    # the LPS read (registers 140, 141) is the second request of a status
    with mangling_proxy(gateway_address, [("pass",), ("fewer", 1)]) as url, open_modbus(
        parse_target(url), timeout=0.2, retries=0
    ) as modbus, pytest.raises(JobError) as caught:
        read_status(modbus)
    assert caught.value.status is JobStatus.INTERFACE_ERROR
    assert "1 registers instead of 2" in str(caught.value)


@pytest.mark.parametrize(
    "mangle", [("reset",), ("fewer", 1), ("short", 2), ("close",), ("flip", 7, 0x10)]
)
def test_cli_status_on_a_bad_gateway_exits_1_with_8383h(gateway_address, mangle):
    with mangling_proxy(gateway_address, [mangle] * 20) as url:
        result = CliRunner().invoke(
            main, ["status", "--modbus", url, "--timeout", "200ms", "--retries", "0"]
        )
    assert result.exit_code == 1, result.output
    assert "8383h" in result.stderr
    assert "internal error" not in result.stderr


# ----- fuzz: whatever the answers, a result or a JobError, never anything else -----------

mangles = st.one_of(
    st.just(("pass",)),
    st.tuples(st.just("cut"), st.integers(0, 40)),
    st.tuples(st.just("short"), st.integers(1, 20)),
    st.tuples(st.just("fewer"), st.integers(1, 15)),
    st.tuples(st.just("flip"), st.integers(0, 40), st.integers(0, 255)),
    st.tuples(st.just("garbage"), st.binary(min_size=1, max_size=30)),
    st.just(("close",)),
    st.just(("reset",)),
)

OPERATIONS: dict[str, Callable] = {
    "status": read_status,
    "upload": upload,
    "entry points": lambda modbus: modbus.entry_points(),
    "start": lambda modbus: set_start(modbus, start=True),
}


MANGLED = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow,
                   HealthCheck.function_scoped_fixture])


@settings(MANGLED, max_examples=25)
@given(plan=st.lists(mangles, min_size=1, max_size=8),
       operation=st.sampled_from(sorted(OPERATIONS)))
def test_mangled_answers_give_a_result_or_a_job_error(gateway_address, plan, operation):
    mangled_answers_give_a_result_or_a_job_error(gateway_address, plan, operation)


@pytest.mark.slow
@settings(MANGLED, max_examples=200)
@given(plan=st.lists(mangles, min_size=1, max_size=8),
       operation=st.sampled_from(sorted(OPERATIONS)))
def test_mangled_answers_give_a_result_or_a_job_error_long(gateway_address, plan, operation):
    mangled_answers_give_a_result_or_a_job_error(gateway_address, plan, operation)


def mangled_answers_give_a_result_or_a_job_error(
    gateway_address: tuple[str, int], plan: list, operation: str
) -> None:
    with no_hang(60), mangling_proxy(gateway_address, plan) as url, open_modbus(
        parse_target(url), timeout=0.05, retries=0
    ) as modbus:
        try:
            OPERATIONS[operation](modbus)
        except JobError as exc:
            # the gateway's own exception answers keep their meaning; all else is 8383h
            expected = {JobStatus.INTERFACE_ERROR, JobStatus.REFUSED, JobStatus.UNKNOWN_COMMAND}
            if operation == "upload":  # a changed image is no valid program
                expected.add(JobStatus.EEPROM_ERROR)
            assert exc.status in expected, exc
        except UserError as exc:  # an upload whose (changed) image is no valid program
            assert operation == "upload", exc
