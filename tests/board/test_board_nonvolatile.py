"""What survives power-off, and the AS-i cable the board is plugged into."""

from __future__ import annotations

import json
import re

import pytest
from board_host import Host

from asictl.board.asi import AsiBus, BusError, Slave
from asictl.board.board import Pc2Board
from asictl.board.execution import Phase
from asictl.board.nonvolatile import NonvolatileError
from asictl.platform import pc2 as d
from asictl.platform.master import EEPROM_SIZE, ControlFlag
from asictl.platform.pc2 import Command


def test_round_trip_through_json(board: Pc2Board, host: Host):
    board.bus.attach(Slave(5, 0x8, 0x0, inputs=3, name="valve"))
    board.bus.attach(Slave(6, 0x1, 0x2, parameter_echo=False, parameter_response=9))
    board.advance(10)
    host.ok(Command.STORE_ACTUAL_CONFIGURATION)
    host.write(d.LOS, d.list_bytes({6}))
    host.ok(Command.SET_LOS)
    host.write(d.CONFIG_OK_DELAY, 7)
    host.download(b"\x01\x02\x03", start=0x100)
    host.ok(Command.SET_OPERATION_MODE, data=0)
    assert host.control_flags(ControlFlag.START | ControlFlag.MAP_COUNTERS) == d.ACK

    saved = json.loads(json.dumps(board.nonvolatile()))
    again = Pc2Board.from_nonvolatile(saved)
    assert again.nonvolatile() == saved
    assert again.eeprom == board.eeprom
    assert again.mode == "protected" and again.dpram[d.CONFIG_OK_DELAY] == 7
    assert again.dpram[d.LPS : d.LPS + 4] == d.list_bytes({5, 6})
    assert again.dpram[d.PCD + 6] == 0x21
    assert again.dpram[d.LOS : d.LOS + 4] == d.list_bytes({6})
    assert again.dpram[d.CONTROL_FLAGS] == ControlFlag.START | ControlFlag.MAP_COUNTERS
    valve = again.bus.slave(5)
    assert (valve.name, valve.inputs, valve.outputs) == ("valve", 3, 0)
    assert not again.bus.slave(6).parameter_echo
    again.advance(30)
    assert again.phase is Phase.NORMAL


def test_a_new_board(board: Pc2Board):
    saved = board.nonvolatile()
    assert saved["eeprom"] == "" and saved["configuration_mode"] is True
    assert saved["lps"] == [] and saved["pcd"] == "ff" * 32 and saved["pp"] == "ff" * 16
    assert saved["config_ok_delay"] == 2 and saved["bus"] == {"powered": True, "slaves": []}


def test_power_fail_is_kept():
    bus = AsiBus([Slave(1)])
    bus.power_fail()
    again = Pc2Board.from_nonvolatile(Pc2Board(bus=bus).nonvolatile())
    again.advance(20)
    assert not again.bus.powered and again.phase is Phase.OFFLINE


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"format": "x"}, "not a saved PC2 board state"),
        ({"version": 9}, "version 9"),
        ({"eeprom": "zz"}, "'eeprom'"),
        ({"eeprom": "00" * (EEPROM_SIZE + 1)}, "at most 16384 bytes"),
        ({"pcd": "ff"}, "'pcd' must be hex text of 32 bytes"),
        ({"pp": None}, "'pp'"),
        ({"lps": [0]}, "'lps' must be a list of slave addresses 1..31"),
        ({"los": [32]}, "'los'"),
        ({"los": "1"}, "'los'"),
        ({"control_flags": 256}, "'control_flags' must be a byte"),
        ({"config_ok_delay": True}, "'config_ok_delay'"),
        ({"configuration_mode": 1}, "'configuration_mode'"),
        ({"bus": {"slaves": [{"address": 40}]}}, "bus: AS-i address must be 0..31"),
        ({"bus": {"slaves": [{"colour": 1}]}}, "unknown slave fields: colour"),
        ({"bus": {"slaves": [{"io_code": "8"}]}}, "'io_code' must be an integer"),
        ({"bus": []}, "bus"),
    ],
)
def test_malformed_state_is_refused(board: Pc2Board, change: dict, message: str):
    saved = board.nonvolatile() | change
    with pytest.raises(NonvolatileError, match=re.escape(message)):
        Pc2Board.from_nonvolatile(saved)


def test_not_an_object():
    with pytest.raises(ValueError, match="must be an object"):
        Pc2Board.from_nonvolatile([])  # type: ignore[arg-type]


def test_bus_operations():
    bus = AsiBus()
    slave = bus.attach(Slave(4, 0x8, 0x0))
    with pytest.raises(BusError, match="already on a bus"):
        bus.attach(slave)
    with pytest.raises(BusError, match=r"0\.\.15"):
        slave.inputs = 16
    with pytest.raises(BusError, match=r"0\.\.31"):
        slave.address = 32
    with pytest.raises(BusError, match="no slaves at address 5"):
        bus.slave(5)
    bus.attach(Slave(4))
    with pytest.raises(BusError, match="2 slaves at address 4"):
        bus.remove(4)
    assert bus.remove(slave) is slave and slave.bus is None
    with pytest.raises(BusError, match="not on this bus"):
        bus.remove(slave)
    assert [s.address for s in bus] == [4] and bus.outputs(4) == 0
    with pytest.raises(BusError, match="negative"):
        slave.lose_telegrams(-1)


def test_slave_answers():
    slave = Slave(7, 0x3, 0xA)
    assert slave.profile == 0xA3
    assert slave.receive_parameter(0x5) == 0x5 and slave.parameter == 5
    slave.parameter_echo, slave.parameter_response = False, 0xC
    assert slave.receive_parameter(0x1) == 0xC
    assert slave.command(0x10) == 0x3 and slave.command(0x11) == 0xA
    assert slave.command(0x1E) == 0 and slave.command(0x02) is None
    slave.outputs = 0xF
    assert slave.command(0x1C) == 0x6 and slave.outputs == 0 and slave.parameter == 0xF
