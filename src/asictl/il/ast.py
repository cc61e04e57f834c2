"""The abstract syntax tree of an AS-i Control IL source file.

Plain frozen dataclasses, one per construct of the programming manual (chapter 3). Every
node carries the ``Span`` it was read from, excluded from equality so that a tree printed
back with ``to_source()`` and read again compares equal to the original (the round-trip
property the tests rely on). Names keep the spelling of the source; the language ignores
case, so comparisons go through ``key()``.

The operand model: every operand of every statement is one ``Operand`` value, whatever
it names: kind (the mark: ``I``, ``FY``, ``T``, ``KT`` ..., or a variable), address (the
number after the mark), bit (after the dot), width (how the statement uses it: ``T 1`` is
a bit in ``A T 1`` and a word in ``L T 1``), a variable's name, and its span. Constants
are operands too (``L KT 500`` loads one), so ``L`` takes an operand like any other
instruction. What reads and writes which operand is answered in one place,
``operands()``: a count (CU, CD, STP) reads and writes its counter, and PARAM writes
``FY 127`` (the slave's answer), an operand the source does not show. ``nodes()`` is the
body of a section, ``Module.statements()`` the statements of a module and
``Module.code()`` those with its gating lines, all that runs. Every walker of
the tree (checks, analyses, formatter, cross-reference, allocator, code generator,
interpreter, editor) goes through these, and every ``match`` over statement or operand
kinds ends in ``assert_never``: mypy then names each walker a new kind is missing from.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from enum import IntEnum, StrEnum
from typing import TypeVar, assert_never

from asictl.diagnostics import Span
from asictl.il.language import PARAM_FLAG


def _span() -> Span | None:
    return field(default=None, compare=False, repr=False)


def key(name: str) -> str:
    """The identity of a name: the language ignores case."""
    return name.casefold()


# --------------------------------------------------------------------------- operands
# 3.4.1 binary operands, 3.4.3 byte and word addresses, 3.4.2 constants


class OperandKind(StrEnum):
    """What an operand names. The value is the mark the source writes before the number
    (a variable's operands start with its name instead)."""

    I = "I"  # noqa: E741 - the manual's own name
    I2 = "I2"
    Q = "Q"
    F = "F"
    IB = "IB"
    I2B = "I2B"
    QB = "QB"
    FY = "FY"
    PSEG = "PSeg"
    FW = "FW"
    T = "T"
    C = "C"
    VAR = "variable"
    KT = "KT"
    KC = "KC"
    KB = "KB"
    KW = "KW"
    KP = "KP"


class Width(IntEnum):
    """How many bits a statement takes of an operand: ``A T 1`` its status bit, ``L T 1``
    its remaining time (a word)."""

    BIT = 1
    #: a slave's four data bits, ``I 4`` or ``Q 17``: no IL statement takes them, the
    #: host tools and scenarios do (``asictl.observe.operands``)
    NIBBLE = 4
    BYTE = 8
    WORD = 16


#: The images' and flags' bits; the slaves' data bits (two slaves to a byte operand).
IMAGE_BITS = frozenset({OperandKind.I, OperandKind.I2, OperandKind.Q, OperandKind.F})
SLAVE_BITS = frozenset({OperandKind.I, OperandKind.I2, OperandKind.Q})
SLAVE_BYTES = frozenset({OperandKind.IB, OperandKind.I2B, OperandKind.QB})
#: The constants ``L`` loads: KB and KW into ACCU1, KT, KC and KP into the constant register.
CONSTANTS = frozenset({
    OperandKind.KT, OperandKind.KC, OperandKind.KB, OperandKind.KW, OperandKind.KP,
})
_WIDTHS = {
    **dict.fromkeys(IMAGE_BITS | {OperandKind.T, OperandKind.C}, Width.BIT),
    **dict.fromkeys(SLAVE_BYTES | {OperandKind.FY, OperandKind.PSEG, OperandKind.KB}, Width.BYTE),
    **dict.fromkeys({OperandKind.FW, OperandKind.KT, OperandKind.KC, OperandKind.KW,
                     OperandKind.KP}, Width.WORD),
}


@dataclass(frozen=True, slots=True, repr=False)
class Operand:
    """One operand of a statement, as the source writes it.

    ``address`` is the number after the mark: the slave (``I 4.0``), the byte (``F 42.7``,
    ``FY 10``, ``PSeg 0``), the word, the timer or counter, a variable's byte offset
    (``Reading 3.2``), a constant's value (``KT 500``), the slave of ``KP 13.9``. ``bit``
    is the number after the dot: the bit, or KP's parameter; -1 where there is none.
    ``width`` is how the statement uses it (a timer is a bit in ``A T 1`` and a word in
    ``L T 1``), ``name`` a variable's name as written. The span takes no part in
    equality: an operand is a value, the span where it was read.
    """

    kind: OperandKind
    address: int
    bit: int = -1
    width: Width = Width.BIT
    name: str = ""
    span: Span | None = field(default=None, compare=False, repr=False)

    @classmethod
    def of(
        cls, kind: OperandKind, address: int, bit: int = -1, *, name: str = "",
        width: Width | None = None, span: Span | None = None,
    ) -> Operand:
        """An operand with the width its kind has where the language takes it whole (a
        timer or counter: its status bit; a variable: a bit with a bit number, else a
        byte)."""
        if width is None:
            if kind is OperandKind.VAR:
                width = Width.BIT if bit >= 0 else Width.BYTE
            else:
                width = _WIDTHS[kind]
        return cls(kind, address, bit, width, name, span)

    def __repr__(self) -> str:
        return f"Operand({self}, {self.width.name.lower()})"

    def __str__(self) -> str:
        head = self.name if self.kind is OperandKind.VAR else self.kind.value
        return f"{head} {self.address}" if self.bit < 0 else f"{head} {self.address}.{self.bit}"

    def slaves(self) -> tuple[int, ...]:
        """The slaves whose data it addresses: one for a bit, two for a byte (IB 4 holds
        slaves 4 and 5)."""
        return slaves_of(self.kind, self.address)


def slaves_of(kind: OperandKind, address: int) -> tuple[int, ...]:
    if kind in SLAVE_BITS:
        return (address,)
    if kind in SLAVE_BYTES:
        return (address, address + 1)
    return ()


def flag_bytes(kind: OperandKind, address: int) -> range:
    """The flag bytes a flag operand covers (FW n is FY n and FY n+1); empty for others."""
    if kind is OperandKind.F or kind is OperandKind.FY:
        return range(address, address + 1)
    if kind is OperandKind.FW:
        return range(address, address + 2)
    return range(0)


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
    operand: Operand
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{self.op.value} {self.operand}"


@dataclass(frozen=True)
class Store:
    """``=``, ``S``, ``R``. On a timer S starts it with the last KT; on a counter S loads KC."""

    op: StoreOp
    operand: Operand
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
    """``L x``: ACCU2 := ACCU1, ACCU1 := x; ``L KT``/``L KC``/``L KP`` instead load the
    constant register (for S T, S C and PARAM) and leave both accumulators alone."""

    operand: Operand
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"L {self.operand}"


@dataclass(frozen=True)
class Transfer:
    """``T x``: store ACCU1 (its low byte for a byte operand)."""

    operand: Operand
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
    counter: Operand
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
    operand: Operand
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

    target: Operand
    terms: tuple[GatingTerm, ...]
    span: Span | None = _span()

    def to_source(self) -> str:
        return f"{self.target} = " + " ".join(t.to_source() for t in self.terms)


# ------------------------------------------------------------------------ the walk


class Access(StrEnum):
    """How a statement uses an operand."""

    READ = "read"
    WRITE = "write"
    #: CU, CD and STP read a counter's value to write it back one up or down
    READ_WRITE = "read and write"


_READ, _WRITE = Access.READ, Access.WRITE
#: An operand and what a statement does with it (a plain tuple: there is one for nearly
#: every line of a program, made in each walk of every check).
Use = tuple[Operand, Access]


def operands(node: Statement | GatingLine | GatingTerm) -> tuple[Use, ...]:
    """The operands a statement, a gating line or a gating term reads and writes, in
    source order (a gating line: its target first).

    Constants are operands that are read. PARAM writes ``FY 127``, the slave's answer,
    which the source does not write: its operand has the span of the PARAM.
    """
    # the most frequent kinds first: every check walks every line
    match node:
        case Logic() | Load():
            return ((node.operand, _READ),)
        case Store() | Transfer():
            return ((node.operand, _WRITE),)
        case SegmentEnd() | Label() | Jump():
            return ()
        case Count():
            return ((node.counter, Access.READ_WRITE),)
        case GatingLine():
            return ((node.target, _WRITE), *((term.operand, _READ) for term in node.terms))
        case GatingTerm():
            return ((node.operand, _READ),)
        case Param():
            answer = Operand(OperandKind.FY, PARAM_FLAG, -1, Width.BYTE, "", node.span)
            return ((answer, _WRITE),)
        case Not() | Arith() | Compare() | BlockEnd() | CallFB() | Asm():
            return ()
        case _:
            assert_never(node)


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


#: What a section's body holds, one node to a line (declarations may share one).
BodyNode = Option | SlaveSetup | Declaration | Statement | GatingLine | AsmLine


def nodes(section: Section) -> tuple[BodyNode, ...]:
    """The nodes of a section's body, in source order ([RAW] records are text)."""
    match section:
        case OptionsSection(options=found) | SetupSection(slaves=found):
            return found
        case DeclSection(declarations=found) | ProgramSection(statements=found):
            return found
        case GatingSection(lines=found) | AssemblySection(lines=found):
            return found
        case RawSection():
            return ()
        case _:
            assert_never(section)


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

    def code(self) -> Iterator[Statement | GatingLine]:
        """What runs: the [PROGRAM] statements and [GATING] lines, in source order."""
        for section in self.sections:
            if isinstance(section, ProgramSection):
                yield from section.statements
            elif isinstance(section, GatingSection):
                yield from section.lines

    def has_assembly(self) -> bool:
        """Whether it holds hand-written assembly, which may read or write anything."""
        return any(self.sections_of(AssemblySection)) \
            or any(isinstance(node, Asm) for node in self.code())
