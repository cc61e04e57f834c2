"""The MCS-51 instruction set as one table, shared by assembler, disassembler and emulator.

Encodings, lengths and cycle counts live only here, so the three tools cannot disagree
about what a byte means. The table is built from the regular layout of the opcode map
(row = operation, column = addressing mode) plus the irregular rows written out.
"""

from __future__ import annotations

import enum
from collections.abc import Iterator
from dataclasses import dataclass


class Operand(enum.Enum):
    """An operand kind; the value is how the instruction set reference writes it."""

    A = "A"
    AB = "AB"
    C = "C"
    DPTR = "DPTR"
    AT_A_DPTR = "@A+DPTR"
    AT_A_PC = "@A+PC"
    AT_DPTR = "@DPTR"
    AT_R0 = "@R0"
    AT_R1 = "@R1"
    R0 = "R0"
    R1 = "R1"
    R2 = "R2"
    R3 = "R3"
    R4 = "R4"
    R5 = "R5"
    R6 = "R6"
    R7 = "R7"
    DIRECT = "direct"
    IMM = "#data"
    IMM16 = "#data16"
    BIT = "bit"
    NBIT = "/bit"
    REL = "rel"
    ADDR11 = "addr11"
    ADDR16 = "addr16"

    @property
    def size(self) -> int:
        """Bytes this operand adds after the opcode (0 for operands coded in the opcode)."""
        return _OPERAND_SIZE.get(self, 0)

    @property
    def is_fixed(self) -> bool:
        """True for register-like operands written literally (A, R3, @DPTR, ...)."""
        return self not in _OPERAND_SIZE


_OPERAND_SIZE: dict[Operand, int] = {
    Operand.DIRECT: 1,
    Operand.IMM: 1,
    Operand.IMM16: 2,
    Operand.BIT: 1,
    Operand.NBIT: 1,
    Operand.REL: 1,
    Operand.ADDR11: 1,
    Operand.ADDR16: 2,
}

#: The eight working registers in opcode order (low three bits of the opcode).
REGISTERS: tuple[Operand, ...] = (
    Operand.R0,
    Operand.R1,
    Operand.R2,
    Operand.R3,
    Operand.R4,
    Operand.R5,
    Operand.R6,
    Operand.R7,
)


@dataclass(frozen=True, slots=True)
class OpcodeInfo:
    """One opcode: what it is written as, how long it is and how its operand bytes follow.

    ``encoding`` lists indices into ``operands`` in the order their bytes follow the
    opcode. It is not always source order: ``MOV direct,direct`` (85h) stores the
    source address first. An ADDR11 operand keeps bits 10-8 in the opcode's top three
    bits and contributes only its low byte.
    """

    opcode: int
    mnemonic: str
    operands: tuple[Operand, ...]
    length: int
    cycles: int
    encoding: tuple[int, ...]


# The register/indirect-addressed block: columns 6..F of rows 0..F, indexed by the
# operand that varies (@R0, @R1, R0..R7). Each entry: (mnemonic, operands with _RR
# in place of the varying operand, cycles).
_INDIRECT_OPERANDS: tuple[Operand, ...] = (Operand.AT_R0, Operand.AT_R1, *REGISTERS)
_RR = None
_REGISTER_ROWS: dict[int, tuple[str, tuple[Operand | None, ...], int]] = {
    0x0: ("INC", (_RR,), 1),
    0x1: ("DEC", (_RR,), 1),
    0x2: ("ADD", (Operand.A, _RR), 1),
    0x3: ("ADDC", (Operand.A, _RR), 1),
    0x4: ("ORL", (Operand.A, _RR), 1),
    0x5: ("ANL", (Operand.A, _RR), 1),
    0x6: ("XRL", (Operand.A, _RR), 1),
    0x7: ("MOV", (_RR, Operand.IMM), 1),
    0x8: ("MOV", (Operand.DIRECT, _RR), 2),
    0x9: ("SUBB", (Operand.A, _RR), 1),
    0xA: ("MOV", (_RR, Operand.DIRECT), 2),
    0xB: ("CJNE", (_RR, Operand.IMM, Operand.REL), 2),
    0xC: ("XCH", (Operand.A, _RR), 1),
    0xD: ("DJNZ", (_RR, Operand.REL), 2),  # but D6h/D7h are XCHD, in _IRREGULAR
    0xE: ("MOV", (Operand.A, _RR), 1),
    0xF: ("MOV", (_RR, Operand.A), 1),
}

Op = Operand
# Columns 0..5 of the opcode map, written out: opcode -> (mnemonic, operands, cycles).
# Column 1 (AJMP/ACALL) is generated.
_IRREGULAR: dict[int, tuple[str, tuple[Operand, ...], int]] = {
    0x00: ("NOP", (), 1),
    0x10: ("JBC", (Op.BIT, Op.REL), 2),
    0x20: ("JB", (Op.BIT, Op.REL), 2),
    0x30: ("JNB", (Op.BIT, Op.REL), 2),
    0x40: ("JC", (Op.REL,), 2),
    0x50: ("JNC", (Op.REL,), 2),
    0x60: ("JZ", (Op.REL,), 2),
    0x70: ("JNZ", (Op.REL,), 2),
    0x80: ("SJMP", (Op.REL,), 2),
    0x90: ("MOV", (Op.DPTR, Op.IMM16), 2),
    0xA0: ("ORL", (Op.C, Op.NBIT), 2),
    0xB0: ("ANL", (Op.C, Op.NBIT), 2),
    0xC0: ("PUSH", (Op.DIRECT,), 2),
    0xD0: ("POP", (Op.DIRECT,), 2),
    0xE0: ("MOVX", (Op.A, Op.AT_DPTR), 2),
    0xF0: ("MOVX", (Op.AT_DPTR, Op.A), 2),
    0x02: ("LJMP", (Op.ADDR16,), 2),
    0x12: ("LCALL", (Op.ADDR16,), 2),
    0x22: ("RET", (), 2),
    0x32: ("RETI", (), 2),
    0x42: ("ORL", (Op.DIRECT, Op.A), 1),
    0x52: ("ANL", (Op.DIRECT, Op.A), 1),
    0x62: ("XRL", (Op.DIRECT, Op.A), 1),
    0x72: ("ORL", (Op.C, Op.BIT), 2),
    0x82: ("ANL", (Op.C, Op.BIT), 2),
    0x92: ("MOV", (Op.BIT, Op.C), 2),
    0xA2: ("MOV", (Op.C, Op.BIT), 1),
    0xB2: ("CPL", (Op.BIT,), 1),
    0xC2: ("CLR", (Op.BIT,), 1),
    0xD2: ("SETB", (Op.BIT,), 1),
    0xE2: ("MOVX", (Op.A, Op.AT_R0), 2),
    0xF2: ("MOVX", (Op.AT_R0, Op.A), 2),
    0x03: ("RR", (Op.A,), 1),
    0x13: ("RRC", (Op.A,), 1),
    0x23: ("RL", (Op.A,), 1),
    0x33: ("RLC", (Op.A,), 1),
    0x43: ("ORL", (Op.DIRECT, Op.IMM), 2),
    0x53: ("ANL", (Op.DIRECT, Op.IMM), 2),
    0x63: ("XRL", (Op.DIRECT, Op.IMM), 2),
    0x73: ("JMP", (Op.AT_A_DPTR,), 2),
    0x83: ("MOVC", (Op.A, Op.AT_A_PC), 2),
    0x93: ("MOVC", (Op.A, Op.AT_A_DPTR), 2),
    0xA3: ("INC", (Op.DPTR,), 2),
    0xB3: ("CPL", (Op.C,), 1),
    0xC3: ("CLR", (Op.C,), 1),
    0xD3: ("SETB", (Op.C,), 1),
    0xE3: ("MOVX", (Op.A, Op.AT_R1), 2),
    0xF3: ("MOVX", (Op.AT_R1, Op.A), 2),
    0x04: ("INC", (Op.A,), 1),
    0x14: ("DEC", (Op.A,), 1),
    0x24: ("ADD", (Op.A, Op.IMM), 1),
    0x34: ("ADDC", (Op.A, Op.IMM), 1),
    0x44: ("ORL", (Op.A, Op.IMM), 1),
    0x54: ("ANL", (Op.A, Op.IMM), 1),
    0x64: ("XRL", (Op.A, Op.IMM), 1),
    0x74: ("MOV", (Op.A, Op.IMM), 1),
    0x84: ("DIV", (Op.AB,), 4),
    0x94: ("SUBB", (Op.A, Op.IMM), 1),
    0xA4: ("MUL", (Op.AB,), 4),
    0xB4: ("CJNE", (Op.A, Op.IMM, Op.REL), 2),
    0xC4: ("SWAP", (Op.A,), 1),
    0xD4: ("DA", (Op.A,), 1),
    0xE4: ("CLR", (Op.A,), 1),
    0xF4: ("CPL", (Op.A,), 1),
    0x05: ("INC", (Op.DIRECT,), 1),
    0x15: ("DEC", (Op.DIRECT,), 1),
    0x25: ("ADD", (Op.A, Op.DIRECT), 1),
    0x35: ("ADDC", (Op.A, Op.DIRECT), 1),
    0x45: ("ORL", (Op.A, Op.DIRECT), 1),
    0x55: ("ANL", (Op.A, Op.DIRECT), 1),
    0x65: ("XRL", (Op.A, Op.DIRECT), 1),
    0x75: ("MOV", (Op.DIRECT, Op.IMM), 2),
    0x85: ("MOV", (Op.DIRECT, Op.DIRECT), 2),
    0x95: ("SUBB", (Op.A, Op.DIRECT), 1),
    0xB5: ("CJNE", (Op.A, Op.DIRECT, Op.REL), 2),
    0xC5: ("XCH", (Op.A, Op.DIRECT), 1),
    0xD5: ("DJNZ", (Op.DIRECT, Op.REL), 2),
    0xE5: ("MOV", (Op.A, Op.DIRECT), 1),
    0xF5: ("MOV", (Op.DIRECT, Op.A), 1),
    0xD6: ("XCHD", (Op.A, Op.AT_R0), 1),
    0xD7: ("XCHD", (Op.A, Op.AT_R1), 1),
}
del Op

#: The one opcode the MCS-51 leaves undefined.
UNDEFINED_OPCODE = 0xA5


def _make(opcode: int, mnemonic: str, operands: tuple[Operand, ...], cycles: int) -> OpcodeInfo:
    encoding = tuple(i for i, op in enumerate(operands) if op.size)
    if opcode == 0x85:  # MOV dst,src stores the source address first
        encoding = (1, 0)
    length = 1 + sum(op.size for op in operands)
    return OpcodeInfo(opcode, mnemonic, operands, length, cycles, encoding)


def _build() -> Iterator[OpcodeInfo]:
    for opcode in range(256):
        row, column = opcode >> 4, opcode & 0x0F
        if opcode in _IRREGULAR:
            yield _make(opcode, *_IRREGULAR[opcode])
        elif column == 1:
            mnemonic = "ACALL" if row & 1 else "AJMP"
            yield _make(opcode, mnemonic, (Operand.ADDR11,), 2)
        elif column >= 6:
            mnemonic, template, cycles = _REGISTER_ROWS[row]
            reg = _INDIRECT_OPERANDS[column - 6]
            operands = tuple(reg if op is None else op for op in template)
            yield _make(opcode, mnemonic, operands, cycles)


_DEFINED = {info.opcode: info for info in _build()}

#: Index = opcode; ``None`` only for the undefined A5h.
OPCODES: tuple[OpcodeInfo | None, ...] = tuple(_DEFINED.get(op) for op in range(256))



# Special function registers of the 8051 and 8052 under the names as31 predefines.
SFRS: dict[str, int] = {
    "P0": 0x80,
    "SP": 0x81,
    "DPL": 0x82,
    "DPH": 0x83,
    "PCON": 0x87,
    "TCON": 0x88,
    "TMOD": 0x89,
    "TL0": 0x8A,
    "TL1": 0x8B,
    "TH0": 0x8C,
    "TH1": 0x8D,
    "P1": 0x90,
    "SCON": 0x98,
    "SBUF": 0x99,
    "P2": 0xA0,
    "IE": 0xA8,
    "P3": 0xB0,
    "IP": 0xB8,
    "T2CON": 0xC8,
    "RCAP2L": 0xCA,
    "RCAP2H": 0xCB,
    "TL2": 0xCC,
    "TH2": 0xCD,
    "PSW": 0xD0,
    "ACC": 0xE0,
    "B": 0xF0,
}


def _bits(base: int, *names: str) -> dict[str, int]:
    """Bit names of one bit-addressable SFR, listed from bit 0 up ('' skips a bit)."""
    return {name: base + i for i, name in enumerate(names) if name}


# Named bits of the bit-addressable SFRs under the names as31 predefines, except two:
# as31 gives T2 and T2EX the addresses 80h and 81h (P0.0, P0.1), but on the 8052 they
# are P1.0 and P1.1. Rather than copy a wrong address or silently differ from as31,
# they are left undefined, so a program that uses them is told so.
SFR_BITS: dict[str, int] = {
    **_bits(0x88, "IT0", "IE0", "IT1", "IE1", "TR0", "TF0", "TR1", "TF1"),
    **_bits(0x98, "RI", "TI", "RB8", "TB8", "REN", "SM2", "SM1", "SM0"),
    **_bits(0xA8, "EX0", "ET0", "EX1", "ET1", "ES", "ET2", "", "EA"),
    **_bits(0xB0, "RXD", "TXD", "INT0", "INT1", "T0", "T1", "WR", "RD"),
    **_bits(0xB8, "PX0", "PT0", "PX1", "PT1", "PS", "PT2"),
    **_bits(0xC8, "", "", "TR2", "EXEN2", "TCLK", "RCLK", "EXF2", "TF2"),
    **_bits(0xD0, "P", "", "OV", "RS0", "RS1", "F0", "AC", "CY"),
}


def is_bit_addressable_byte(address: int) -> bool:
    """True if ``address.n`` names a bit: RAM 20h..2Fh or an SFR at a multiple of 8."""
    return 0x20 <= address <= 0x2F or (address >= 0x80 and address % 8 == 0 and address <= 0xF8)


def bit_address(byte_address: int, bit: int) -> int:
    """The bit address of bit ``bit`` of a bit-addressable byte (20h.3 -> 03h, ACC.7 -> E7h)."""
    if byte_address < 0x80:
        return (byte_address - 0x20) * 8 + bit
    return byte_address + bit
