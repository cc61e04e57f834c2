"""The Modbus places ``asictl xref --modbus`` gives each operand, read off the emulated
gateway: the program's images are put where the master keeps them (the input data of
the bus, the output image, the flags in the communication memory) and the gateway is
asked at the place the table names."""

from __future__ import annotations

import re

from modbus_helpers import bits, read_holding, read_input

from asictl.board.board import Pc2Board
from asictl.gateway.slave import GatewaySlave
from asictl.il.crossref import modbus_places
from asictl.platform import pc2 as d

_PLACE = re.compile(r"(coil|discrete input|input register|holding register) (\d+)(?: bits? (\d+))?")


def read_place(gw: GatewaySlave, place: str) -> int:
    """The bit a place names (or, without a bit, the whole register)."""
    kind, address, bit = _PLACE.fullmatch(place).groups()
    if kind == "coil":
        return int(bits(gw, 1, int(address), 1)[0])
    if kind == "discrete input":
        return int(bits(gw, 2, int(address), 1)[0])
    reader = read_input if kind == "input register" else read_holding
    value = reader(gw, int(address))[0]
    return value if bit is None else value >> int(bit) & 1


def test_inputs_are_discrete_inputs_and_input_register_bits(gw: GatewaySlave, board: Pc2Board):
    for slave in (1, 13):  # the fixture's input and bidirectional slaves
        for bit in range(4):
            board.bus.set_inputs(slave, 1 << bit)
            board.advance(10)
            places = modbus_places("I", slave, bit, map_counters=False)
            assert [read_place(gw, p) for p in places] == [1, 1], places
            board.bus.set_inputs(slave, 0)
            board.advance(10)
            assert [read_place(gw, p) for p in places] == [0, 0]


def test_outputs_are_coils_and_holding_register_bits(gw: GatewaySlave, board: Pc2Board):
    for slave in (2, 6, 13, 31):
        for bit in range(4):
            image = bytearray(16)  # the program's Q image: slave 2k+1 in the high nibble
            image[slave // 2] = 1 << (slave % 2 * 4 + bit)
            gw.map.driver.write(d.ODI, bytes(255 - b for b in image))
            places = modbus_places("Q", slave, bit, map_counters=False)
            assert [read_place(gw, p) for p in places] == [1, 1], places


def test_flags_are_holding_registers_of_the_user_memory(gw: GatewaySlave, board: Pc2Board):
    for byte in (0, 3, 42, 127):
        for bit in (0, 2, 7):
            gw.map.driver.write(d.FLAGS, bytes(128))
            gw.map.driver.write_byte(d.FLAGS + byte, 1 << bit)
            places = modbus_places("F", byte, bit, map_counters=False)
            assert [read_place(gw, p) for p in places] == [1, 1], places
    gw.map.driver.write(d.FLAGS + 10, bytes([0x12, 0x34]))
    assert modbus_places("FW", 10, map_counters=False) == [
        "holding register 805"]
    assert read_holding(gw, 805) == [0x1234]
    byte = modbus_places("FY", 11, map_counters=False)[0]
    assert read_place(gw, byte) == 0x34


def test_the_issues_examples():
    def first(mark: str, number: int, bit: int) -> str:
        return modbus_places(mark, number, bit, map_counters=False)[0]

    assert first("Q", 2, 0) == "coil 8"
    assert first("F", 3, 2) == "holding register 403 bit 2"
    assert first("I", 1, 0) == "discrete input 4"
