"""The three-register port (manual 7.2): data, INDEX, PAGE with the reset bit."""

from __future__ import annotations

from itertools import pairwise

import pytest
from board_host import Host

from asictl.board.asi import AsiBus, Slave
from asictl.board.board import Pc2Board
from asictl.board.execution import Phase
from asictl.board.images import VERSION_ID
from asictl.platform import pc2 as d


def test_every_data_access_increments_index(board: Pc2Board, host: Host):
    host.seek(0x210)
    for value in (1, 2, 3):
        board.io_write(d.PORT_DATA, value)
    assert board.dpram[0x210:0x213] == b"\x01\x02\x03"
    host.seek(0x211)
    assert [board.io_read(d.PORT_DATA) for _ in range(2)] == [2, 3]


def test_after_byte_255_index_and_page_wrap_to_page_0(board: Pc2Board, host: Host):
    host.seek(0x2FE)
    for value in (0xA1, 0xA2, 0xA3):
        board.io_write(d.PORT_DATA, value)
    assert board.dpram[0x2FE:0x300] == b"\xa1\xa2"
    assert board.dpram[0x000] == 0xA3 and board.dpram[0x300] != 0xA3
    host.seek(0x1FF)
    board.io_read(d.PORT_DATA)
    assert board.io_read(d.PORT_DATA) == 0xA3  # byte 000h, not 200h


def test_page_register_uses_bits_0_and_1(board: Pc2Board):
    board.io_write(d.PORT_PAGE, 0x0F & ~d.PAGE_RESET_BIT)  # bits 2-3 ignored
    board.io_write(d.PORT_INDEX, 0x04)
    assert board.io_read(d.PORT_DATA) == board.dpram[0x304]


def test_index_and_page_read_as_ffh(board: Pc2Board):
    board.io_write(d.PORT_INDEX, 0x12)
    board.io_write(d.PORT_PAGE, 0x01)
    assert board.io_read(d.PORT_INDEX) == 0xFF
    assert board.io_read(d.PORT_PAGE) == 0xFF
    assert board.io_read(d.PORT_DATA) == board.dpram[0x112]  # registers unchanged


def test_one_dpram_byte_is_the_byte_the_whole_copy_has(board: Pc2Board, host: Host):
    host.seek(d.FLAGS)
    for value in (0x5A, 0xA5):
        board.io_write(d.PORT_DATA, value)
    board.advance(20.0)  # the master writes its images and answers meanwhile
    whole = board.dpram
    assert [board.dpram_byte(a) for a in range(d.DPRAM_SIZE)] == list(whole)
    for outside in (-1, d.DPRAM_SIZE):
        with pytest.raises(IndexError, match="outside 000h-3FFh"):
            board.dpram_byte(outside)


@pytest.mark.parametrize("offset", [-1, 3, 7])
def test_other_offsets_are_not_decoded(board: Pc2Board, offset: int):
    with pytest.raises(ValueError, match=r"offsets 0\.\.2"):
        board.io_read(offset)
    with pytest.raises(ValueError, match=r"offsets 0\.\.2"):
        board.io_write(offset, 0)


def test_writes_carry_one_byte(board: Pc2Board):
    with pytest.raises(ValueError, match="one byte"):
        board.io_write(d.PORT_DATA, 0x100)


def test_power_up_dpram(board: Pc2Board):
    ram = board.dpram
    assert ram[d.ODI : d.ODI + 16] == b"\xff" * 16  # outputs 0, stored inverted
    assert ram[d.MASTER_NAME : d.MASTER_NAME + 4] == b"AS-i"
    assert ram[d.VERSION_ID : d.VERSION_ID + 8] == VERSION_ID
    assert ram[d.CDI : d.CDI + 32] == b"\xff" * 32
    assert ram[d.PCD : d.PCD + 32] == b"\xff" * 32
    assert ram[d.PP : d.PP + 16] == b"\xff" * 16
    assert ram[d.CONFIG_OK_DELAY] == 2
    assert ram[d.COMMAND] == 0
    assert ram[d.COMM_MEMORY : d.COMM_MEMORY + 256] == bytes(256)
    assert d.EcFlag(ram[d.EC_FLAGS]) == d.EcFlag.CONFIGURATION_ACTIVE | d.EcFlag.OFFLINE_READY


def test_odi_is_stored_inverted(board: Pc2Board, host: Host):
    slave = board.bus.attach(Slave(3, 0x8, 0))  # four outputs
    board.advance(5)
    assert host.slaves(d.LAS) == {3}
    host.write(d.ODI + 1, 0xFF ^ 0x50)  # slave 3: high nibble of byte 1
    board.advance(1)
    assert slave.outputs == 0x5
    host.write(d.ODI + 1, 0xFF)
    board.advance(1)
    assert slave.outputs == 0


def test_reset_bit_restarts_the_board_keeping_non_volatile_state(board: Pc2Board, host: Host):
    slave = board.bus.attach(Slave(3, 0x8, 0))
    board.advance(5)
    host.write(d.LPS, d.list_bytes({3}))
    host.ok(d.Command.SET_LPS)
    host.write(d.COMM_MEMORY, b"\x55\x66")
    host.write(d.ODI + 1, 0xFF ^ 0x70)
    board.advance(2)
    assert slave.outputs == 7
    before = board.now_ms

    board.io_write(d.PORT_PAGE, d.PAGE_RESET_BIT)
    assert board.in_reset and slave.outputs == 0
    board.advance(200)
    assert board.phase is Phase.OFFLINE or board.in_reset
    board.io_write(d.PORT_PAGE, 0)
    assert not board.in_reset
    assert board.now_ms == before + 200  # time went on
    assert board.dpram[d.COMM_MEMORY : d.COMM_MEMORY + 2] == b"\0\0"  # volatile: gone
    assert board.dpram[d.ODI + 1] == 0xFF
    assert host.slaves(d.LPS) == {3}  # non-volatile: kept
    board.advance(5)
    assert board.phase is Phase.NORMAL and host.slaves(d.LAS) == {3}
    assert slave.outputs == 0


def test_reset_bit_also_selects_the_page(board: Pc2Board):
    board.io_write(d.PORT_PAGE, d.PAGE_RESET_BIT | 2)
    board.io_write(d.PORT_INDEX, 0)
    board.io_write(d.PORT_DATA, 0x42)
    assert board.dpram[0x200] == 0x42


def test_a_board_on_a_shared_bus_object():
    bus = AsiBus([Slave(1, 0, 0)])
    board = Pc2Board(bus=bus)
    assert board.bus is bus


def test_fixed_cycle_period_and_observer(board: Pc2Board):
    board.bus.attach(Slave(1, 0, 0))
    seen: list[float] = []
    board.cycle_period_us = 1000
    board.observer = lambda: seen.append(board.now_ms)
    board.advance(10)
    steps = {round(b - a, 6) for a, b in pairwise(seen)}
    assert steps == {1.0}  # cycles with nothing to do are skipped, not observed
    with pytest.raises(ValueError, match="positive"):
        board.cycle_period_us = 0
    board.cycle_period_us = None
    assert board.cycle_period_us is None
