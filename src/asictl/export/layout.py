"""Where each IL operand lives on an S7 CPU: the process-image layout of an export.

The AS-i images keep the master's packing (docs/migrate.md): two slaves to a byte, slave
2n in the low nibble, so ``I a.b`` is input bit ``(a % 2) * 4 + b`` of byte ``a // 2``,
``IB n`` is ``IB n/2``; the outputs likewise. Flags keep their numbers (``F y.b`` is
``M y.b``, ``FW n`` is ``MW n``, both big-endian words). What has no S7 area of its own
lives in data blocks: the IL machine's registers, the previous inputs (I2) and PSeg in
``DB 1``, the timers' remaining ticks in ``DB 2``, the counters in ``DB 3``, the declared
variables one after the other in ``DB 4``. One place says this; the AWL generator, the
map file and the check all ask it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import assert_never

from asictl.il import ast
from asictl.il.language import COUNTER_FLAG_BASE, MAPPED_COUNTERS
from asictl.platform.master import flag_keeps

K = ast.OperandKind

#: The data blocks of an export.
STATE_DB = 1
TIMER_DB = 2
COUNTER_DB = 3
VARIABLE_DB = 4

#: DB 1: the IL machine: the single-bit register, a status bit read for T and C,
#: ACCU1, ACCU2, the constant register, the 10 ms clock, I2, the last inputs, PSeg.
RLO = f"DB{STATE_DB}.DBX 0.0"
STATUS = f"DB{STATE_DB}.DBX 0.1"
ACCU1 = f"DB{STATE_DB}.DBW 2"
ACCU1_LOW = f"DB{STATE_DB}.DBB 3"
ACCU2_LOW = f"DB{STATE_DB}.DBB 5"
ACCU2 = f"DB{STATE_DB}.DBW 4"
KREG = f"DB{STATE_DB}.DBW 6"
CLOCK_LAST = f"DB{STATE_DB}.DBD 8"
CLOCK_REST = f"DB{STATE_DB}.DBD 12"
TICKS = f"DB{STATE_DB}.DBD 16"
I2_BASE = 32
PREVIOUS_BASE = 48
PSEG_BASE = 64
STATE_SIZE = 80
#: the bytes of each AS-i image (32 slaves, two to a byte)
IMAGE_BYTES = 16


def slave_bit(slave: int, bit: int) -> tuple[int, int]:
    """The image byte and bit of a slave's data bit: two slaves to a byte, the odd one in
    the high nibble."""
    return slave // 2, (slave % 2) * 4 + bit


@dataclass(frozen=True)
class Layout:
    """The S7 address of every operand of one program."""

    #: key(variable name) -> its first byte in DB 4
    variables: dict[str, int]
    #: how many bytes the variables take in DB 4
    variable_bytes: int
    #: counters 0..14 live in flag bytes 96..125 (the option map_counters)
    map_counters: bool

    def bit(self, operand: ast.Operand) -> str:
        """The S7 bit of an I, I2, Q, F or variable bit operand."""
        a, b = operand.address, operand.bit
        match operand.kind:
            case K.I | K.Q:
                byte, bit = slave_bit(a, b)
                return f"{operand.kind.value} {byte}.{bit}"
            case K.I2:
                byte, bit = slave_bit(a, b)
                return f"DB{STATE_DB}.DBX {I2_BASE + byte}.{bit}"
            case K.F:
                return f"M {a}.{b}"
            case K.VAR:
                return f"DB{VARIABLE_DB}.DBX {self.variables[ast.key(operand.name)] + a}.{b}"
            case (
                K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.FW | K.T | K.C | K.KT | K.KC | K.KB |
                K.KW | K.KP
            ):
                raise AssertionError(f"{operand} has no S7 bit")
            case _:
                assert_never(operand.kind)

    def byte(self, operand: ast.Operand) -> str:
        """The S7 byte of an IB, I2B, QB, FY, PSeg or variable byte operand."""
        a = operand.address
        match operand.kind:
            case K.IB:
                return f"IB {a // 2}"
            case K.QB:
                return f"QB {a // 2}"
            case K.I2B:
                return f"DB{STATE_DB}.DBB {I2_BASE + a // 2}"
            case K.FY:
                return f"MB {a}"
            case K.PSEG:
                return f"DB{STATE_DB}.DBB {PSEG_BASE + a}"
            case K.VAR:
                return f"DB{VARIABLE_DB}.DBB {self.variables[ast.key(operand.name)] + a}"
            case K.I | K.I2 | K.Q | K.F | K.FW | K.T | K.C | K.KT | K.KC | K.KB | K.KW | K.KP:
                raise AssertionError(f"{operand} has no S7 byte")
            case _:
                assert_never(operand.kind)

    def flag(self, operand: ast.Operand) -> str:
        """The S7 address of a flag bit, byte or word (F, FY, FW)."""
        if operand.kind is K.FW:
            return f"MW {operand.address}"
        return self.bit(operand) if operand.kind is K.F else self.byte(operand)

    @staticmethod
    def timer(n: int) -> str:
        """Timer n's remaining time in 10 ms ticks."""
        return f"DB{TIMER_DB}.DBW {2 * n}"

    def keeps(self, n: int) -> int:
        """The bits of flag byte ``n`` that keep what the program writes. With map_counters
        the upper four bits of a mapped counter's high byte (FY 97, 99 .. 125) stay 0 on
        the master whatever is written there, so an export masks its writes to them and a
        read-back in the same cycle sees what the master's would."""
        return flag_keeps(n, self.map_counters)

    def held_at_zero(self, operand: ast.Operand) -> str | None:
        """Why writing the bit operand changes nothing, or None when it can: a flag bit
        the master holds at 0 (``keeps``), for which an export writes this reason as a
        comment instead of the =, S or R."""
        if operand.kind is not K.F or self.keeps(operand.address) >> operand.bit & 1:
            return None
        counter = (operand.address - COUNTER_FLAG_BASE) // 2
        return (f"{operand} stays 0 on the master (bits 4-7 of counter {counter}'s high "
                "byte with map_counters): nothing to write")

    def counter_mapped(self, n: int) -> bool:
        return self.map_counters and n < MAPPED_COUNTERS

    @staticmethod
    def counter(n: int) -> str:
        """Counter n's count, where it is not mapped onto the flags."""
        return f"DB{COUNTER_DB}.DBW {2 * n}"

    @staticmethod
    def mapped_counter_bytes(n: int) -> tuple[str, str]:
        """A mapped counter's low and high flag bytes (low byte first, as on the master)."""
        low = COUNTER_FLAG_BASE + 2 * n
        return f"MB {low}", f"MB {low + 1}"


def layout_of(modules: list[ast.Module], map_counters: bool) -> Layout:
    """Place the declared variables one after the other in DB 4, in declaration order."""
    places: dict[str, int] = {}
    offset = 0
    for module in modules:
        for section in module.sections_of(ast.DeclSection):
            for decl in section.declarations:
                if isinstance(decl, ast.VarDecl) and ast.key(decl.name) not in places:
                    places[ast.key(decl.name)] = offset
                    offset += decl.size
    return Layout(places, offset, map_counters)
