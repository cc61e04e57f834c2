"""The opcode table against independent facts about the MCS-51."""

from __future__ import annotations

import pytest

from asictl.mcs51.isa import (
    OPCODES,
    SFR_BITS,
    SFRS,
    Operand,
    bit_address,
    is_bit_addressable_byte,
)
from asictl.mcs51.words import MNEMONICS

# Instruction lengths as printed in the Intel opcode map, one row per high nibble
# (0 = undefined). Written out independently of the table's generator.
INTEL_LENGTHS = """
    1231121111111111
    3231121111111111
    3211221111111111
    3211221111111111
    2223221111111111
    2223221111111111
    2223221111111111
    2221232222222222
    2221132222222222
    3221221111111111
    2221102222222222
    2221333333333333
    2221121111111111
    2221131122222222
    1211121111111111
    1211121111111111
"""


def defined():
    return [info for info in OPCODES if info is not None]


def test_table_has_256_entries_and_only_a5_undefined():
    assert len(OPCODES) == 256
    assert len(defined()) == 255
    assert OPCODES[0xA5] is None


def test_every_entry_sits_at_its_own_opcode():
    assert all(info.opcode == index for index, info in enumerate(OPCODES) if info)


def test_lengths_match_the_intel_opcode_map():
    expected = [int(c) for c in "".join(INTEL_LENGTHS.split())]
    assert [info.length if info else 0 for info in OPCODES] == expected


def test_length_is_opcode_plus_operand_bytes():
    for info in defined():
        assert info.length == 1 + sum(op.size for op in info.operands), hex(info.opcode)


def test_encoding_names_each_byte_carrying_operand_once():
    for info in defined():
        carrying = {i for i, op in enumerate(info.operands) if op.size}
        assert sorted(info.encoding) == sorted(carrying), hex(info.opcode)


def test_mov_direct_direct_stores_source_first():
    info = OPCODES[0x85]
    assert info.mnemonic == "MOV"
    assert info.operands == (Operand.DIRECT, Operand.DIRECT)
    assert info.encoding == (1, 0)
    assert info.length == 3


@pytest.mark.parametrize(("opcode", "mnemonic"), [(0xA4, "MUL"), (0x84, "DIV")])
def test_mul_and_div_take_four_cycles(opcode, mnemonic):
    assert OPCODES[opcode].mnemonic == mnemonic
    assert OPCODES[opcode].operands == (Operand.AB,)
    assert OPCODES[opcode].cycles == 4


@pytest.mark.parametrize(
    ("opcode", "cycles"),
    [
        (0x00, 1),
        (0x02, 2),
        (0x22, 2),
        (0x75, 2),
        (0x88, 2),
        (0xA8, 2),
        (0xA2, 1),
        (0x92, 2),
        (0xE0, 2),
        (0x93, 2),
        (0xA3, 2),
        (0xD6, 1),
        (0x76, 1),
        (0xC0, 2),
    ],
)
def test_spot_cycle_counts(opcode, cycles):
    assert OPCODES[opcode].cycles == cycles


def test_only_mul_and_div_take_four_cycles():
    assert {i.mnemonic for i in defined() if i.cycles == 4} == {"MUL", "DIV"}
    assert {i.cycles for i in defined()} == {1, 2, 4}


def test_ajmp_and_acall_fill_column_one():
    for opcode in range(0x01, 0x100, 0x10):
        info = OPCODES[opcode]
        assert info.mnemonic == ("ACALL" if opcode & 0x10 else "AJMP")
        assert info.operands == (Operand.ADDR11,)
        assert info.length == 2


def test_there_are_44_mnemonics():
    # the 111 instruction types of the Intel manual, counted by mnemonic
    assert len(MNEMONICS) == 44
    assert {"MOVC", "MOVX", "XCHD", "DA", "JBC", "RETI"} <= MNEMONICS


def test_the_word_list_has_the_mnemonics_of_the_table():
    assert {info.mnemonic for info in OPCODES if info is not None} == MNEMONICS


def test_sfr_spot_values():
    assert SFRS["ACC"] == 0xE0
    assert SFRS["PSW"] == 0xD0
    assert SFRS["SBUF"] == 0x99
    assert SFR_BITS["CY"] == 0xD7
    assert SFR_BITS["EA"] == 0xAF
    assert SFR_BITS["TR0"] == 0x8C
    assert SFR_BITS["RI"] == 0x98
    assert "T2" not in SFR_BITS


def test_bit_names_lie_in_their_sfr():
    for name, bit in SFR_BITS.items():
        assert bit >= 0x80 and is_bit_addressable_byte(bit & 0xF8), name


@pytest.mark.parametrize(
    ("byte", "bit", "expected"),
    [(0x20, 0, 0x00), (0x20, 3, 0x03), (0x2F, 7, 0x7F), (0xE0, 7, 0xE7), (0x88, 4, 0x8C)],
)
def test_bit_address(byte, bit, expected):
    assert bit_address(byte, bit) == expected


@pytest.mark.parametrize("byte", [0x1F, 0x30, 0x81, 0x87, 0x99])
def test_not_bit_addressable(byte):
    assert not is_bit_addressable_byte(byte)
