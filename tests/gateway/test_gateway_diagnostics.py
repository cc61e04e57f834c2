"""Function 8: counters, diagnostic register, listen-only mode, restart; broadcasts."""

from __future__ import annotations

import struct

from modbus_helpers import exception, read_holding, request

from asictl.board.execution import Phase
from asictl.platform import pc2 as d


def counter(gw, code: int) -> int:
    response = request(gw, 8, "HH", code, 0)
    assert response is not None and response[:3] == bytes([8, 0, code])
    return struct.unpack(">H", response[3:])[0]


def test_return_query_data_echoes(gw):
    assert request(gw, 8, "HHH", 0, 0x1234, 0xABCD) == struct.pack(">BHHH", 8, 0, 0x1234, 0xABCD)


def test_counters_count_what_happened(gw):
    read_holding(gw, 0)
    exception(gw, 3, "HH", 9, 1)
    gw.frame(1, b"\x03\x00\x00\x00\x01", crc_ok=False)
    gw.frame(5, b"\x03\x00\x00\x00\x01")  # another slave's telegram
    request(gw, 6, "HH", 400, 1, unit=0)  # broadcast: executed, not answered
    # 5 frames on the bus, 4 to us (one with a bad CRC), 1 exception, 2 unanswered
    assert counter(gw, 11) == 6  # ... plus this query
    assert counter(gw, 12) == 1
    assert counter(gw, 13) == 1
    assert counter(gw, 14) == 7  # 2 good to us + broadcast + the four counter queries
    assert counter(gw, 15) == 2
    assert [counter(gw, c) for c in (16, 17, 18)] == [0, 0, 0]
    assert request(gw, 8, "HH", 10, 0) == bytes([8, 0, 10, 0, 0])
    assert counter(gw, 11) == 1


def test_broadcast_executes_writes_only(gw, board):
    assert request(gw, 6, "HH", 401, 0x42, unit=0) is None
    assert board.dpram[d.FLAGS + 1] == 0x42
    assert request(gw, 3, "HH", 401, 1, unit=0) is None
    assert request(gw, 16, "HHBHH", 402, 2, 4, 7, 8, unit=0) is None
    assert board.dpram[d.FLAGS + 2 : d.FLAGS + 4] == b"\x07\x08"


def test_diagnostic_register_is_ec_and_hi_flags(gw, board):
    value = counter(gw, 2)
    assert value == board.dpram[d.EC_FLAGS] | board.dpram[d.HI_FLAGS] << 8
    assert value & d.EcFlag.NORMAL_OPERATION_ACTIVE


def test_listen_only_until_restart(gw, board):
    assert request(gw, 8, "HH", 4, 0) is None  # no answer to the request itself
    assert gw.listen_only
    assert request(gw, 3, "HH", 0, 1) is None
    assert request(gw, 6, "HH", 400, 9) is None
    assert board.dpram[d.FLAGS] == 0  # ignored, not executed
    assert request(gw, 8, "HH", 11, 0) is None
    assert request(gw, 8, "HH", 1, 0) is None  # restart leaves listen-only silently
    assert not gw.listen_only
    assert read_holding(gw, 400) == [0]
    assert counter(gw, 14) == 2  # counters were cleared by the restart


def test_restart_turns_the_watchdog_off_and_restarts_the_master(gw, board):
    request(gw, 6, "HH", 1008, 20)
    assert request(gw, 8, "HH", 1, 0xFF00) == bytes([8, 0, 1, 0xFF, 0])
    assert read_holding(gw, 1008) == [0]
    assert board.dpram[d.WATCHDOG_ENABLE] == 0
    board.advance(20)
    assert board.phase is Phase.NORMAL


def test_diagnostic_values_checked(gw):
    assert exception(gw, 8, "HH", 1, 0x1234) == 3
    assert exception(gw, 8, "HH", 4, 1) == 3
    assert exception(gw, 8, "HH", 3, 0) == 1
    assert exception(gw, 8, "H", 11) == 3
    assert not gw.listen_only
