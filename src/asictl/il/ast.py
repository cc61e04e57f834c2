"""The abstract syntax tree of an AS-i Control IL source file.

Plain frozen dataclasses, one per construct of the programming manual (chapter 3). Every
node carries the ``Span`` it was read from, excluded from equality so that a tree printed
back with ``to_source()`` and read again compares equal to the original (the round-trip
property the tests rely on). Names keep the spelling of the source; the language ignores
case, so comparisons go through ``key()``.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from enum import StrEnum
from typing import TypeVar

from asictl.diagnostics import Span


def _span() -> Span | None:
    return field(default=None, compare=False, repr=False)


def key(name: str) -> str:
    """The identity of a name: the language ignores case."""
    return name.casefold()


# --------------------------------------------------------------------------- operands
# 3.4.1 binary operands, 3.4.3 byte and word addresses, 3.4.2 constants


class BitArea(StrEnum):
    """Bit-addressable images: ``I 4.0`` input, ``I2`` previous input, ``Q`` output, ``F`` flag."""

    I = "I"  # noqa: E741 - the manual's own name
    I2 = "I2"
    Q = "Q"
    F = "F"


class ByteArea(StrEnum):
    """Byte-addressable images (3.4.3). IB/I2B/QB take an even slave address."""

    IB = "IB"
    I2B = "I2B"
    QB = "QB"
    FY = "FY"
    PSEG = "PSeg"


@dataclass(frozen=True)
class ImageBit:
    """``I 4.0``: slave 4, data bit 0 (I, I2, Q); ``F 42.7``: flag byte 42, bit 7."""

    area: BitArea
    address: int
    bit: int
    span: Span | None = _span()

    def __str__(self) -> str:
        return f"{self.area.value} {self.address}.{self.bit}"


@dataclass(frozen=True)
class TimerRef:
    """``T n``: the status bit as a bit operand, the remaining time as a word operand."""

    number: int
    span: Span | None = _span()

    def __str__(self) -> str:
        return f"T {self.number}"


@dataclass(frozen=True)
class CounterRef:
    """``C n``: the status bit as a bit operand, the count as a word operand."""

    number: int
    span: Span | None = _span()

    def __str__(self) -> str:
        return f"C {self.number}"


@dataclass(frozen=True)
class VarBit:
    """``Reading 3.2``: bit 2 of byte 3 of a variable declared in [DECL]."""

    name: str
    offset: int
    bit: int
    span: Span | None = _span()

    def __str__(self) -> str:
        return f"{self.name} {self.offset}.{self.bit}"


@dataclass(frozen=True)
class ImageByte:
    """``IB 4``, ``I2B 4``, ``QB 16``, ``FY 10``, ``PSeg 0``."""

    area: ByteArea
    number: int
    span: Span | None = _span()

    def __str__(self) -> str:
        return f"{self.area.value} {self.number}"


@dataclass(frozen=True)
class VarByte:
    """``Reading 3``: byte 3 of a variable declared in [DECL]."""

    name: str
    offset: int
    span: Span | None = _span()

    def __str__(self) -> str:
        return f"{self.name} {self.offset}"


@dataclass(frozen=True)
class FlagWord:
    """``FW n``: FY n is the high byte and FY n+1 the low byte, as in STEP5."""

    number: int
    span: Span | None = _span()

    def __str__(self) -> str:
        return f"FW {self.number}"


class ConstKind(StrEnum):
    """The constant forms of ``L`` (3.4.2)."""

    KT = "KT"  # time in milliseconds, 0..40950
    KC = "KC"  # counter value, 0..4095
    KB = "KB"  # byte, 0..255
    KW = "KW"  # word, 0..65535


@dataclass(frozen=True)
class Constant:
    """``KT 500``, ``KC 10``, ``KB 0Ah``, ``KW 1000``."""

    kind: ConstKind
    value: int
    span: Span | None = _span()

    def __str__(self) -> str:
        return f"{self.kind.value} {self.value}"


@dataclass(frozen=True)
class ParamConst:
    """``KP 13.9``: send parameter 9 to slave 13 (with PARAM)."""

    address: int
    data: int
    span: Span | None = _span()

    def __str__(self) -> str:
        return f"KP {self.address}.{self.data}"


BitOperand = ImageBit | TimerRef | CounterRef | VarBit
ByteOperand = ImageByte | VarByte
WordOperand = FlagWord | TimerRef | CounterRef
LoadOperand = Constant | ParamConst | ImageByte | VarByte | FlagWord | TimerRef | CounterRef
TransferOperand = ImageByte | VarByte | FlagWord | TimerRef | CounterRef


# ----------------------------------------------------------------------- instructions


class LogicOp(StrEnum):
    A = "A"
    AN = "AN"
    O = "O"  # noqa: E741 - the manual's own name
    ON = "ON"


class StoreOp(StrEnum):
    """Operators that write a bit operand from the register without changing it."""

    ASSIGN = "="
    SET = "S"
    RESET = "R"


class ArithOp(StrEnum):
    ADD = "+"
    SUB = "-"


class CompareOp(StrEnum):
    """Byte comparisons. Mind the manual: ``!=`` tests EQUALITY and ``><`` inequality."""

    EQ = "!="
    NE = "><"
    GT = ">"
    GE = ">="
    LT = "<"
    LE = "<="


class CountOp(StrEnum):
    CU = "CU"
    CD = "CD"
    STP = "STP"


class EndKind(StrEnum):
    BE = "BE"
    BEC = "BEC"
    BEU = "BEU"


@dataclass(frozen=True)
class Logic:
    """A/AN/O/ON: combine the single-bit register with a bit operand (or load it, first check)."""

    op: LogicOp
    operand: BitOperand
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{self.op.value} {self.operand}"


@dataclass(frozen=True)
class Store:
    """``=``, ``S``, ``R``. On a timer S starts it with the last KT; on a counter S loads KC."""

    op: StoreOp
    operand: BitOperand
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{self.op.value} {self.operand}"


@dataclass(frozen=True)
class Not:
    """``N``: invert the single-bit register."""

    span: Span | None = _span()

    def to_source(self) -> str:
        return "N"


@dataclass(frozen=True)
class Load:
    """``L x``: ACCU2 := ACCU1, ACCU1 := x (constants also preset the timer/counter/KP value)."""

    operand: LoadOperand
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"L {self.operand}"


@dataclass(frozen=True)
class Transfer:
    """``T x``: store ACCU1 (its low byte for a byte operand)."""

    operand: TransferOperand
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"T {self.operand}"


@dataclass(frozen=True)
class Arith:
    """``+ F`` / ``- F``: ACCU1 := ACCU2 op ACCU1, bytes modulo 256."""

    op: ArithOp
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{self.op.value} F"


@dataclass(frozen=True)
class Compare:
    """``!= F`` etc.: register := ACCU2 op ACCU1 (bytes, unsigned)."""

    op: CompareOp
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{self.op.value} F"


@dataclass(frozen=True)
class Count:
    """``CU C n``, ``CD C n`` (when the register is 1), ``STP C n`` (up on 1, down on 0)."""

    op: CountOp
    counter: CounterRef
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{self.op.value} {self.counter}"


@dataclass(frozen=True)
class SegmentEnd:
    """``***``: the register becomes undefined; the next A/O loads it (first check)."""

    span: Span | None = _span()

    def to_source(self) -> str:
        return "***"


@dataclass(frozen=True)
class BlockEnd:
    """``BE``/``BEU`` end the cycle (or return from a block); ``BEC`` when the register is 1."""

    kind: EndKind
    span: Span | None = _span()

    def to_source(self) -> str:
        return self.kind.value


@dataclass(frozen=True)
class Jump:
    """``JU = label`` / ``JC = label``."""

    conditional: bool
    label: str
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{'JC' if self.conditional else 'JU'} = {self.label}"


@dataclass(frozen=True)
class CallFB:
    """``JU FB name`` / ``JC FB name``: a user block declared in [DECL] or a firmware block."""

    conditional: bool
    name: str
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{'JC' if self.conditional else 'JU'} FB {self.name}"


@dataclass(frozen=True)
class Param:
    """``PARAM``: send the last KP to its slave when the register is 1 (firmware SendPrm)."""

    span: Span | None = _span()

    def to_source(self) -> str:
        return "PARAM"


@dataclass(frozen=True)
class Asm:
    """``ASM text``: the rest of the line goes to the assembler unexamined."""

    text: str
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"ASM {self.text}"


@dataclass(frozen=True)
class Label:
    """``name:`` marks a jump target; it does not start a new logic string."""

    name: str
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{self.name}:"


Statement = (
    Logic | Store | Not | Load | Transfer | Arith | Compare | Count | SegmentEnd | BlockEnd
    | Jump | CallFB | Param | Asm | Label
)


# --------------------------------------------------------------------------- [GATING]


class GatingOp(StrEnum):
    AND = "and"
    OR = "or"


@dataclass(frozen=True)
class GatingTerm:
    """One ``[and|or] [not] source`` of a gating line; the first term has no operator."""

    op: GatingOp | None
    negated: bool
    operand: BitOperand
    span: Span | None = _span()

    def to_source(self) -> str:
        parts = [self.op.value] if self.op else []
        if self.negated:
            parts.append("not")
        parts.append(str(self.operand))
        return " ".join(parts)


@dataclass(frozen=True)
class GatingLine:
    """``Q 17.3 = I 4.0 or I 5.0 and not F 42.7``: evaluated strictly left to right."""

    target: BitOperand
    terms: tuple[GatingTerm, ...]
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{self.target} = " + " ".join(t.to_source() for t in self.terms)


# -------------------------------------------------------------------------- sections


@dataclass(frozen=True)
class Option:
    """``auto_start: yes`` (3.1)."""

    name: str
    value: bool
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{self.name}: {'yes' if self.value else 'no'}"


@dataclass(frozen=True)
class SlaveSetup:
    """``16: iiio, 1, Eh`` (3.2): address, I/O code, ID code, power-up parameter (None: F)."""

    address: int
    io_code: int
    id_code: int
    parameter: int | None = None
    span: Span | None = _span()

    def to_source(self) -> str:
        text = f"{self.address}: {self.io_code:X}h, {self.id_code:X}h"
        return text if self.parameter is None else f"{text}, {self.parameter:X}h"


@dataclass(frozen=True)
class VarDecl:
    """``Reading BYTE 5``: a variable of ``size`` bytes."""

    name: str
    size: int
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{self.name} BYTE {self.size}"


@dataclass(frozen=True)
class TimerDecl:
    """``T134 TIMER``: timers above 14 must be declared."""

    number: int
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"T{self.number} TIMER"


@dataclass(frozen=True)
class CounterDecl:
    """``C27 COUNTER``: counters above 14 must be declared."""

    number: int
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"C{self.number} COUNTER"


@dataclass(frozen=True)
class FBDecl:
    """``MEAN FB MEAN.FB``: a user function block and the file holding its source."""

    name: str
    file: str
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{self.name} FB {self.file}"


Declaration = VarDecl | TimerDecl | CounterDecl | FBDecl


class SectionKind(StrEnum):
    OPTIONS = "OPTIONS"
    SETUP = "SETUP"
    DECL = "DECL"
    PROGRAM = "PROGRAM"
    GATING = "GATING"
    ASSEMBLY = "ASSEMBLY"
    RAW = "RAW"


@dataclass(frozen=True)
class OptionsSection:
    options: tuple[Option, ...]
    span: Span | None = _span()
    kind = SectionKind.OPTIONS

    def body(self) -> list[str]:
        return [o.to_source() for o in self.options]


@dataclass(frozen=True)
class SetupSection:
    slaves: tuple[SlaveSetup, ...]
    span: Span | None = _span()
    kind = SectionKind.SETUP

    def body(self) -> list[str]:
        return [s.to_source() for s in self.slaves]


@dataclass(frozen=True)
class DeclSection:
    declarations: tuple[Declaration, ...]
    span: Span | None = _span()
    kind = SectionKind.DECL

    def body(self) -> list[str]:
        return [d.to_source() for d in self.declarations]


@dataclass(frozen=True)
class ProgramSection:
    statements: tuple[Statement, ...]
    span: Span | None = _span()
    kind = SectionKind.PROGRAM

    def body(self) -> list[str]:
        return [
            s.to_source() if isinstance(s, Label) else f"    {s.to_source()}"
            for s in self.statements
        ]


@dataclass(frozen=True)
class GatingSection:
    lines: tuple[GatingLine, ...]
    span: Span | None = _span()
    kind = SectionKind.GATING

    def body(self) -> list[str]:
        return [g.to_source() for g in self.lines]


@dataclass(frozen=True)
class AsmLine:
    """One line of an [ASSEMBLY] section, passed to the assembler as written."""

    text: str
    span: Span | None = _span()


@dataclass(frozen=True)
class AssemblySection:
    lines: tuple[AsmLine, ...]
    span: Span | None = _span()
    kind = SectionKind.ASSEMBLY

    def body(self) -> list[str]:
        return [line.text for line in self.lines]


@dataclass(frozen=True)
class RawSection:
    """Intel HEX records of an uploaded image (3.7)."""

    records: tuple[str, ...]
    span: Span | None = _span()
    kind = SectionKind.RAW

    def body(self) -> list[str]:
        return list(self.records)


Section = (
    OptionsSection | SetupSection | DeclSection | ProgramSection | GatingSection
    | AssemblySection | RawSection
)
_SectionT = TypeVar("_SectionT", bound=Section)


@dataclass(frozen=True)
class Module:
    """One source file: a main program or a function block's file."""

    file: str
    sections: tuple[Section, ...]

    def to_source(self) -> str:
        out: list[str] = []
        for section in self.sections:
            out.append(f"[{section.kind.value}]")
            out.extend(section.body())
            out.append("")
        out.append("[END]")
        return "\n".join(out) + "\n"

    def sections_of(self, kind: type[_SectionT]) -> list[_SectionT]:
        return [s for s in self.sections if isinstance(s, kind)]

    def statements(self) -> Iterator[Statement]:
        """The statements of all its program sections, in order."""
        for section in self.sections_of(ProgramSection):
            yield from section.statements
