"""The gateway on the wire: pymodbus (and mbpoll) as clients over TCP and RTU on a pty pair.

Every server binds to 127.0.0.1 and stops when its ``with`` block ends.
"""

from __future__ import annotations

import os
import select
import subprocess
import threading
import time
import tty
from collections.abc import Iterator

import pytest
from pymodbus.client import ModbusSerialClient, ModbusTcpClient

from asictl.board.execution import Phase
from asictl.board.images import VERSION_ID
from asictl.gateway.server import SerialSettings, background_gateway, crc16
from asictl.gateway.slave import GATEWAY_NAME, GatewaySlave
from asictl.host.transports import gateway_pdus as pdus
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.platform import pc2 as d
from asictl.platform.master import EEPROM_SIZE


@pytest.fixture
def tcp(board) -> Iterator[tuple[ModbusTcpClient, object]]:
    with background_gateway(GatewaySlave(board)) as gateway:
        host, port = gateway.server.tcp_address
        client = ModbusTcpClient(host, port=port, timeout=2, retries=0)
        for cls in pdus.CLIENT_PDUS:
            client.register(cls)
        assert client.connect()
        try:
            yield client, gateway
        finally:
            client.close()


def test_tcp_documented_addresses(tcp, board):
    client, gateway = tcp
    assert client.read_discrete_inputs(400, count=16, device_id=1).bits[:16] == [
        a in (1, 6, 13) for a in range(16)
    ]
    assert client.read_input_registers(106, count=1, device_id=1).registers == [0x82]
    assert not client.write_register(1, 0x00F0, device_id=1).isError()
    assert client.read_coils(24, count=4, device_id=1).bits[:4] == [True] * 4
    assert not client.write_registers(400, [1, 2, 3], device_id=1).isError()
    assert client.read_holding_registers(800, count=2, device_id=1).registers == [0x0102, 0x0300]
    error = client.read_holding_registers(0, count=16, device_id=1)
    assert error.isError() and error.exception_code == 3
    error = client.read_coils(1000, count=1, device_id=1)
    assert error.isError() and error.exception_code == 2
    time.sleep(0.1)  # the master runs by itself: the outputs reach the slave
    assert gateway.call(lambda: board.bus.outputs(6)) == 0xF


def test_tcp_function_65_names_the_gateway_in_full(tcp):
    """P = 1: the master name in 32 characters and a NUL (gateway manual 6.3.12)."""
    client, _ = tcp
    name = client.execute(False, pdus.MasterInfoRequest(pdus.INFO_NAME, dev_id=1))
    assert name.text == GATEWAY_NAME
    raw = pdus.MasterInfoResponse(GATEWAY_NAME, pdus.INFO_NAME).encode()  # B, D1 ... D33
    assert raw[0] == 33 and raw[1 : 1 + len(GATEWAY_NAME)] == GATEWAY_NAME.encode("ascii")
    version_id = client.execute(False, pdus.MasterInfoRequest(pdus.INFO_VERSION_ID, dev_id=1))
    assert version_id.text == VERSION_ID.decode("ascii")


def test_tcp_user_functions_share_the_eeprom_with_the_pc2_port(tcp, board):
    client, gateway = tcp
    info = client.execute(False, pdus.MasterInfoRequest(pdus.INFO_SOFTWARE, dev_id=1))
    assert info.text == "cBFE....DoA...wT"  # E: the EMC test mode, as the master
    assert "VAG-MOD-KF-R4" in client.execute(False, pdus.MasterInfoRequest(1, dev_id=1)).text
    blocks = [bytes((16 * k + i) & 0xFF for i in range(16)) for k in range(4)]
    for k, block in enumerate(blocks):
        response = client.execute(False, pdus.DownloadRequest(0x100 + 16 * k, block, dev_id=1))
        assert response.address == 0x100 + 16 * k
    upload = client.execute(False, pdus.UploadRequest(address=0x110, dev_id=1))
    assert upload.data == blocks[1]

    def through_pc2_port() -> bytes:
        driver = Pc2Driver(EmulatedPort(board))
        driver.command(d.Command.UPLOAD, 64, 0x00, 0x01)
        return driver.read(d.PROGRAM_BUFFER, 64)

    assert gateway.call(through_pc2_port) == b"".join(blocks)
    error = client.execute(False, pdus.UploadRequest(address=EEPROM_SIZE, dev_id=1))
    assert error.isError() and error.exception_code == 2


def test_tcp_watchdog_is_live(tcp, board):
    client, gateway = tcp
    assert not client.write_register(1008, 5, device_id=1).isError()  # 50 ms
    deadline = time.monotonic() + 3
    while gateway.call(lambda: board.phase) is not Phase.OFFLINE:
        assert time.monotonic() < deadline, "the Modbus watchdog never fired"
        time.sleep(0.02)
    assert client.read_coils(129, count=1, device_id=1).bits[0]


def test_tcp_listen_only_and_broadcast(tcp, board):
    client, gateway = tcp
    client.write_register(405, 0x55, device_id=0, no_response_expected=True)
    assert client.read_holding_registers(405, count=1, device_id=1).registers == [0x55]
    client.diag_force_listen_only(device_id=1, no_response_expected=True)
    time.sleep(0.05)
    assert gateway.call(lambda: gateway.server.slave.listen_only)
    client.diag_restart_communication(False, device_id=1, no_response_expected=True)
    time.sleep(0.05)
    assert client.diag_read_device_message_count(device_id=1).message == 1


# ---------------------------------------------------------------------- RTU over ptys


def _pty() -> tuple[int, str]:
    master, slave = os.openpty()
    tty.setraw(slave)
    name = os.ttyname(slave)
    os.close(slave)
    return master, name


@pytest.fixture
def rtu_line(board) -> Iterator[tuple[int, str, object]]:
    """The gateway on one pty; the test gets the other side's master fd and a device name.

    A relay thread joins the two ptys' master ends, as socat would: the gateway opens
    pty A's device, pymodbus opens pty B's, raw-byte tests write to B's master end instead.
    """
    a_master, a_name = _pty()
    with background_gateway(GatewaySlave(board), tcp=None, rtu=SerialSettings(a_name)) as gw:
        yield a_master, a_name, gw
    os.close(a_master)


def _raw_exchange(fd: int, frame: bytes, wait: float = 0.3) -> bytes:
    os.write(fd, frame)
    out = b""
    deadline = time.monotonic() + wait
    while time.monotonic() < deadline:
        ready, _, _ = select.select([fd], [], [], 0.02)
        if ready:
            out += os.read(fd, 256)
    return out


def _frame(body: bytes) -> bytes:
    return body + crc16(body)


def test_rtu_raw_frames_crc_errors_and_counters(rtu_line, board):
    fd, _, _ = rtu_line
    answer = _raw_exchange(fd, _frame(bytes([1, 4, 0, 106, 0, 1])))
    assert answer == _frame(bytes([1, 4, 2, 0, 0x82]))
    bad = bytearray(_frame(bytes([1, 3, 0, 0, 0, 1])))
    bad[-1] ^= 0xFF
    assert _raw_exchange(fd, bytes(bad)) == b""
    assert _raw_exchange(fd, b"\x01\x03") == b""  # too short to be a telegram
    assert _raw_exchange(fd, _frame(bytes([9, 3, 0, 0, 0, 1]))) == b""  # someone else's
    assert _raw_exchange(fd, _frame(bytes([1, 0x2B, 0x0E, 1, 0]))) == _frame(bytes([1, 0xAB, 1]))
    crc_errors = _raw_exchange(fd, _frame(bytes([1, 8, 0, 12, 0, 0])))
    assert crc_errors == _frame(bytes([1, 8, 0, 12, 0, 2]))
    bus = _raw_exchange(fd, _frame(bytes([1, 8, 0, 11, 0, 0])))
    assert bus == _frame(bytes([1, 8, 0, 11, 0, 7]))


def test_rtu_pymodbus_client_through_a_pty_relay(rtu_line, board):
    a_master, _, gateway = rtu_line
    b_master, b_name = _pty()
    stop = threading.Event()

    def relay() -> None:
        while not stop.is_set():
            ready, _, _ = select.select([a_master, b_master], [], [], 0.02)
            for fd in ready:
                try:
                    data = os.read(fd, 512)
                except OSError:
                    continue
                os.write(b_master if fd == a_master else a_master, data)

    thread = threading.Thread(target=relay, daemon=True)
    thread.start()
    client = ModbusSerialClient(b_name, baudrate=9600, timeout=1, retries=0)
    for cls in pdus.CLIENT_PDUS:
        client.register(cls)
    try:
        assert client.connect()
        assert not client.write_register(1, 0x00A0, device_id=1).isError()
        assert client.read_holding_registers(1, count=1, device_id=1).registers == [0x00A0]
        assert client.read_input_registers(9, count=2, device_id=1).registers == [
            (1 << 1) | (1 << 6) | (1 << 13), 0
        ]
        block = bytes(range(16))
        assert client.execute(False, pdus.DownloadRequest(0x20, block, dev_id=1)).address == 0x20
        assert client.execute(False, pdus.UploadRequest(address=0x20, dev_id=1)).data == block
        error = client.read_holding_registers(2000, count=1, device_id=1)
        assert error.isError() and error.exception_code == 2
    finally:
        client.close()
        stop.set()
        thread.join(2)
        os.close(b_master)
    assert gateway.call(lambda: board.eeprom[0x20:0x30]) == block


# ---------------------------------------------------------------------- mbpoll


def test_mbpoll_over_tcp(board, mbpoll_path: str):
    mbpoll = mbpoll_path
    with background_gateway(GatewaySlave(board)) as gateway:
        host, port = gateway.server.tcp_address
        base = [mbpoll, "-m", "tcp", "-p", str(port), "-a", "1", "-0", "-1", "-t", "4"]
        subprocess.run([*base, "-r", "400", host, "77", "88"], check=True, timeout=10,
                       capture_output=True)
        out = subprocess.run([*base, "-r", "400", "-c", "2", host], check=True, timeout=10,
                             capture_output=True, text=True).stdout
    assert "[400]: \t77" in out and "[401]: \t88" in out, out
