"""The disassembler: exact round trips through the assembler, and readable output."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from intelhex import IntelHex

from asictl.mcs51.assembler import assemble_text
from asictl.mcs51.disassembler import decode, disassemble
from asictl.mcs51.isa import OPCODES

OPERAND_PATTERNS = (b"\x00\x00", b"\xff\xff", b"\x7f\x80", b"\x80\x7f", b"\x20\x2f")


def round_trip(data: bytes, origin: int = 0) -> dict[int, int]:
    source = disassemble(data, origin=origin)
    assembly = assemble_text(source)
    assert not assembly.diagnostics, (source, assembly.diagnostics)
    return assembly.byte_map()


def as_map(data: bytes, origin: int = 0) -> dict[int, int]:
    return {origin + i: b for i, b in enumerate(data)}


def test_every_opcode_round_trips():
    for info in OPCODES:
        if info is None:
            continue
        for pattern in OPERAND_PATTERNS:
            data = bytes([info.opcode]) + pattern[: info.length - 1]
            for origin in (0x0000, 0x0800, 0xFFFF - info.length + 1):
                assert round_trip(data, origin) == as_map(data, origin), hex(info.opcode)


def test_undefined_opcode_becomes_db():
    assert disassemble(b"\xa5\x00").splitlines() == [
        "        ORG     0000h",
        "        DB      0A5h",
        "        NOP",
    ]


def test_instruction_cut_off_at_the_end_becomes_db():
    source = disassemble(b"\x00\x02\x12", origin=0x100)
    assert source.splitlines()[-2:] == ["        DB      02h", "        DB      12h"]
    assert round_trip(b"\x00\x02\x12", 0x100) == as_map(b"\x00\x02\x12", 0x100)


def test_gaps_become_org_and_jump_targets_become_labels():
    image = IntelHex()
    image.frombytes(bytes([0x80, 0xFE, 0x02, 0x12, 0x00]), offset=0)  # SJMP $; LJMP 1200h
    image.frombytes(bytes([0x22]), offset=0x1200)  # RET
    assert disassemble(image).splitlines() == [
        "        ORG     0000h",
        "L0000:  SJMP    L0000",
        "        LJMP    L1200",
        "        ORG     1200h",
        "L1200:  RET",
    ]


def test_operands_are_written_by_name_and_in_source_order():
    lines = [
        line.strip()
        for line in disassemble(
            bytes(
                [
                    0x85,
                    0x40,
                    0x30,
                    0xE5,
                    0xE0,
                    0xD2,
                    0xD7,
                    0xC2,
                    0x93,
                    0xB0,
                    0x0B,
                    0x74,
                    0xFF,
                    0x90,
                    0x00,
                    0x05,
                    0xE1,
                    0x23,
                ]
            )
        ).splitlines()[1:]
    ]
    assert lines == [
        "MOV     30h,40h",
        "MOV     A,ACC",
        "SETB    CY",
        "CLR     P1.3",
        "ANL     C,/21h.3",
        "MOV     A,#0FFh",
        "MOV     DPTR,#0005h",
        "AJMP    0723h",
    ]


def test_decode_reports_targets():
    [sjmp, ajmp] = decode(bytes([0x80, 0x10, 0x41, 0x23]), 0x0800)
    assert sjmp.target == 0x0812
    assert ajmp.target == 0x0A23
    assert ajmp.info is OPCODES[0x41]


def test_assembled_program_round_trips_through_intel_hex():
    program = assemble_text(
        "\torg 30h\nmain:\tmov a,#1\n\tjz main\n\tacall sub\n\torg 200h\nsub:\tret\n"
    )
    again = assemble_text(disassemble(IntelHex(program.to_intelhex())))
    assert again.byte_map() == program.byte_map()


@settings(max_examples=300, deadline=None)
@given(
    data=st.binary(min_size=1, max_size=64),
    origin=st.one_of(st.just(0), st.integers(0, 0xFFFF), st.sampled_from([0x7F0, 0xFFC0])),
)
def test_random_bytes_round_trip(data, origin):
    origin = min(origin, 0x10000 - len(data))
    assert round_trip(data, origin) == as_map(data, origin)


def test_bytes_above_the_code_space_are_refused():
    with pytest.raises(ValueError, match="above FFFFh"):
        disassemble(b"\x00\x00", origin=0xFFFF)
