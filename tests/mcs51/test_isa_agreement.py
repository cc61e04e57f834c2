"""The assembler and the disassembler read the instruction table the same way."""

from __future__ import annotations

import pytest

from asictl.mcs51.assembler import assemble_text
from asictl.mcs51.disassembler import decode, format_instruction
from asictl.mcs51.isa import OPCODES

DEFINED = [info for info in OPCODES if info is not None]


@pytest.mark.parametrize("info", DEFINED, ids=lambda info: f"{info.opcode:02X}")
def test_disassembly_reassembles_to_the_table_entry(info):
    data = bytes([info.opcode, 0x25, 0x31])[: info.length]
    [item] = decode(data, 0x0400)
    assert item.info is info
    assert len(item.data) == info.length
    assembly = assemble_text(f"\torg 400h\n\t{format_instruction(item)}\n")
    entry = next(e for e in assembly.listing if e.data)
    assert entry.data == data
    assert entry.cycles == info.cycles
    assert len(entry.data) == info.length
