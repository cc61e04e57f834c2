"""The firmware function blocks (manual 3.8) on a live master, PSeg in, PSeg out."""

from __future__ import annotations

import pytest

from asictl.board.asi import Slave
from asictl.board.board import Pc2Board
from asictl.board.services import ERROR, OK, MasterFirmware
from asictl.platform import pc2 as d
from asictl.platform.master import EEPROM_SIZE
from asictl.runtime.firmware import FIRMWARE_BLOCKS


@pytest.fixture
def firmware(board: Pc2Board) -> MasterFirmware:
    board.bus.attach(Slave(1, 0x0, 0x1))
    board.bus.attach(Slave(9, 0x8, 0x0))
    board.bus.attach(Slave(30, 0x8, 0x0))
    board.advance(20)  # configuration mode: 1, 9, 30 active
    return MasterFirmware(board.execution, bytearray(b"\xff" * EEPROM_SIZE), b"IDENTITY")


def call(firmware: MasterFirmware, name: str, *args: int) -> bytearray:
    pseg = bytearray(16)
    pseg[: len(args)] = bytes(args)
    firmware.call(name, pseg)
    return pseg


def test_every_block_is_served(firmware: MasterFirmware):
    for block in FIRMWARE_BLOCKS.values():
        call(firmware, block.name)
    assert firmware.calls == 16


def test_lists_come_slaves_24_to_31_first(firmware: MasterFirmware):
    assert call(firmware, "GetLAS")[:5] == bytes([OK, 0x40, 0x00, 0x02, 0x02])
    assert call(firmware, "GetLDS")[:5] == bytes([OK, 0x40, 0x00, 0x02, 0x02])
    assert call(firmware, "GetLPS")[:5] == bytes([OK, 0, 0, 0, 0])


def test_profiles_and_parameters(firmware: MasterFirmware):
    assert call(firmware, "GetCDI", 1)[:2] == bytes([OK, 0x10])
    assert call(firmware, "GetPCD", 1)[:2] == bytes([OK, 0xFF])
    assert call(firmware, "GetPI", 9)[:2] == bytes([OK, 0xF])
    assert call(firmware, "GetPP", 40)[0] == ERROR


def test_set_pp_and_send_prm(firmware: MasterFirmware, board: Pc2Board):
    assert call(firmware, "SetPP", 9, 0x4)[0] == OK
    assert board.execution.pp[9] == 4 and call(firmware, "GetPP", 9)[1] == 4
    assert call(firmware, "SetPP", 9, 0x10)[0] == ERROR  # not a parameter
    assert call(firmware, "SendPrm", 9, 0x7)[:2] == bytes([OK, 7])
    assert board.bus.slave(9).parameter == 7 and call(firmware, "GetPI", 9)[1] == 7
    assert call(firmware, "SendPrm", 5, 0x7)[0] == ERROR  # no slave 5
    assert call(firmware, "SendPrm", 99, 0x7)[0] == ERROR


def test_address_codes(firmware: MasterFirmware, board: Pc2Board):
    assert call(firmware, "Address", 5, 6)[0] == 0x82
    assert call(firmware, "Address", 1, 9)[0] == 0x84
    assert call(firmware, "Address", 1, 7)[0] == OK
    board.advance(5)
    assert 7 in d.slave_list(board.dpram[d.LDS : d.LDS + 4])
    board.bus.attach(Slave(0, 0x0, 0x0))
    board.advance(5)
    assert call(firmware, "Address", 7, 8)[0] == 0x83


def test_data_exchange_and_auto_address_switches(firmware: MasterFirmware, board: Pc2Board):
    assert call(firmware, "DataEx", 1)[0] == OK
    assert not board.execution.data_exchange_active
    assert call(firmware, "DataEx", 0)[0] == OK and board.execution.data_exchange_active
    assert call(firmware, "AutoAddr", 0)[0] == OK and not board.execution.auto_address_enable
    board.advance(2)
    assert board.dpram[d.HI_FLAGS] == d.HiFlag.AUTO_ADDRESS_OFF


def test_command(firmware: MasterFirmware):
    assert call(firmware, "Command", 9, 0x10)[:2] == bytes([OK, 0x8])
    assert call(firmware, "Command", 9, 0x03)[0] == ERROR
    assert call(firmware, "Command", 4, 0x10)[0] == ERROR


def test_eeprom_blocks(firmware: MasterFirmware):
    written = call(firmware, "WrEeprom", 2, 0x3F, 0xFE, 0xA1, 0xA2)
    assert written[:2] == b"\xa1\xa2"
    assert firmware.eeprom[0x3FFE:0x4000] == b"\xa1\xa2" and firmware.eeprom[0x3FFD] == 0xFF
    refused = call(firmware, "WrEeprom", 3, 0x3F, 0xFE, 1, 2, 3)
    assert refused[:3] == bytes([3, 0x3F, 0xFE]) and firmware.eeprom[0x3FFE] == 0xA1
    assert call(firmware, "RdEeprom", 2, 0x3F, 0xFE)[:2] == b"\xa1\xa2"
    assert call(firmware, "RdEeprom", 3, 0x3F, 0xFE)[:3] == bytes([3, 0x3F, 0xFE])  # 16 KB
    assert call(firmware, "RdEeprom", 9, 0, 0)[:3] == bytes([9, 0, 0])  # 1..8 bytes
    assert call(firmware, "GetId")[:8] == b"IDENTITY"
