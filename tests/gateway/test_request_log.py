"""``gateway serve --verbose``: one line per request on stderr (unit, function, address,
quantity, outcome), what an integrator debugging a Modbus master reads."""

from __future__ import annotations

import os
import re
import signal
import struct
import subprocess
import sys
from pathlib import Path

from pymodbus.client import ModbusTcpClient

from asictl.gateway.slave import GatewaySlave
from asictl.host.transports import gateway_pdus as pdus


def _logged(gw: GatewaySlave) -> list[str]:
    lines: list[str] = []
    gw.request_log = lines.append
    return lines


def _request(code: int, *words: int) -> bytes:
    return bytes([code]) + struct.pack(f">{len(words)}H", *words)


def test_each_frame_is_one_line_with_its_outcome(gw: GatewaySlave):
    lines = _logged(gw)
    assert gw.frame(1, _request(3, 1000, 2)) is not None
    assert gw.frame(1, _request(3, 2000, 1))[0] == 0x83
    assert gw.frame(5, _request(4, 9, 2)) is None
    assert gw.frame(1, _request(3, 0, 1), crc_ok=False) is None
    assert gw.frame(0, _request(6, 8, 0)) is None
    assert gw.frame(1, bytes([0x2B, 0x0E, 1, 0]))[0] == 0xAB
    assert gw.frame(1, _request(5, 3, 0xFF00)) is not None
    assert gw.frame(1, bytes([pdus.FC_UPLOAD, 2, 0x01, 0x20])) is not None
    assert gw.frame(1, _request(8, 4, 0)) is None
    assert gw.frame(1, _request(3, 0, 1)) is None
    stamp = r"\d\d:\d\d:\d\d\.\d{3} "
    expected = [
        "unit 1 fc 3 (read holding registers) address 1000 (41001) quantity 2 -> ok",
        "unit 1 fc 3 (read holding registers) address 2000 (42001) quantity 1 -> "
        "exception 2 (illegal data address)",
        "unit 5 fc 4 (read input registers) address 9 (30010) quantity 2 -> ignored "
        "(this gateway is unit 1)",
        "unit 1 fc 3 (read holding registers) address 0 (40001) quantity 1 -> no answer "
        "(CRC error)",
        "unit 0 fc 6 (write single register) address 8 (40009) value 0000h -> no answer "
        "(broadcast)",
        "unit 1 fc 43 (unknown function) -> exception 1 (illegal function)",
        "unit 1 fc 5 (write single coil) address 3 (00004) value FF00h -> ok",
        "unit 1 fc 67 (EEPROM read) address 0120h quantity 16 -> ok",
        "unit 1 fc 8 (diagnostics) sub-function 4 -> no answer (listen-only mode)",
        "unit 1 fc 3 (read holding registers) address 0 (40001) quantity 1 -> no answer "
        "(listen-only mode)",
    ]
    assert len(lines) == len(expected)
    for line, text in zip(lines, expected, strict=True):
        assert re.fullmatch(stamp + re.escape(text), line), line


def test_no_log_unless_asked(gw: GatewaySlave):
    assert gw.request_log is None
    assert gw.frame(1, _request(3, 1000, 2)) is not None


def test_serve_verbose_logs_requests_on_stderr(tmp_path: Path):
    env = {**os.environ, "ASICTL_STATE_DIR": str(tmp_path)}
    server = subprocess.Popen(
        [sys.executable, "-m", "asictl", "gateway", "serve", "--tcp", "127.0.0.1:0",
         "--verbose"],
        stderr=subprocess.PIPE, text=True, env=env,
    )
    try:
        assert server.stderr is not None
        match = re.search(r"tcp 127\.0\.0\.1:(\d+)", server.stderr.readline())
        assert match
        client = ModbusTcpClient("127.0.0.1", port=int(match.group(1)), timeout=2, retries=0)
        assert client.connect()
        assert not client.read_holding_registers(1009, count=1, device_id=1).isError()
        assert client.read_input_registers(500, count=1, device_id=1).isError()
        client.close()
    finally:
        server.send_signal(signal.SIGINT)
        _, err = server.communicate(timeout=20)
    assert server.returncode == 0
    requests = [line for line in err.splitlines() if " fc " in line]
    assert len(requests) == 2, err
    assert requests[0].endswith(
        "unit 1 fc 3 (read holding registers) address 1009 (41010) quantity 1 -> ok"
    )
    assert requests[1].endswith(
        "unit 1 fc 4 (read input registers) address 500 (30501) quantity 1 -> "
        "exception 2 (illegal data address)"
    )
