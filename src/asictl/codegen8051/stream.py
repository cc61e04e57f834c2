"""Instruction objects and the output stream the code generator writes them into.

The emitter builds every instruction as an object: its mnemonic, its operands (a register,
a direct byte, a bit, an immediate value, a reference to a symbol) and the IL span it
implements. The stream is the one place objects become anything else: the text of each
line for the listing, the assembler's parsed form of the same line for the bytes (no
generated text is read back), and the span of every line for the line map. As in ppci's
output streams, the instruction selector only says what to emit and the stream decides
how it is written out.

Three things follow from holding objects rather than text:

- The peephole rules compare instructions and operands, not spellings.
- Jump targets, block calls and firmware calls are references (``Ref``): the assembler
  resolves them, and the firmware entry points a program uses are read off its
  references (``references``), never searched for in its text.
- A conditional jump to an IL label (``Branch``) is relaxed: every one starts in its short
  form (``JC rel``, 2 bytes); where the first pass of the assembler puts its target out
  of reach it grows to ``JNC skip / LJMP target`` (5 bytes), and the layout is redone
  until no jump needs to grow. Jumps only grow, so this ends, after at most as many
  rounds as there are jumps; code stays compact without guessing distances.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import assert_never

from asictl.diagnostics import Diagnostic, DiagnosticError, Span
from asictl.mcs51 import isa
from asictl.mcs51.asm_expr import Expr, Number, SymbolRef
from asictl.mcs51.asm_parser import (
    Directive,
    Instruction,
    Label,
    ParsedLine,
    ParsedOperand,
    Shape,
    parse_line,
    referenced_symbols,
)
from asictl.mcs51.assembler import Layout, ParsedSource, locate
from asictl.mcs51.assembly import Assembly
from asictl.source import SourceText

#: The name generated assembly goes by in listings and internal diagnostics.
GENERATED = "<generated>"
_INDENT = " " * 8
#: The reach of a short relative jump from the end of its instruction.
_REACH = range(-128, 128)
_SHORT_JUMP = 2


def hex_number(value: int) -> str:
    """An assembler number: 0A5h style, always starting with a digit."""
    return f"0{value:X}h"


# ----------------------------------------------------------------------- operands


@dataclass(frozen=True, slots=True)
class Reg:
    """A register written by its name: A, C, DPTR, @DPTR, R0-R7."""

    name: str
    kind: isa.Operand

    def text(self) -> str:
        return self.name

    def parsed(self, column: int) -> ParsedOperand:
        return ParsedOperand(Shape.REGISTER, column, len(self.name), register=self.kind)


A = Reg("A", isa.Operand.A)
C = Reg("C", isa.Operand.C)
DPTR = Reg("DPTR", isa.Operand.DPTR)
AT_DPTR = Reg("@DPTR", isa.Operand.AT_DPTR)
R0, R1, R2, R3, R4, R5, R6, R7 = (Reg(f"R{n}", isa.Operand[f"R{n}"]) for n in range(8))


@dataclass(frozen=True, slots=True)
class Direct:
    """A byte of internal RAM or an SFR, by address (shown by its SFR name if it has one)."""

    address: int
    name: str | None = None

    def text(self) -> str:
        return self.name or hex_number(self.address)

    def parsed(self, column: int) -> ParsedOperand:
        return _value(Shape.VALUE, column, self.text(), Number(column, 1, self.address))


DPL = Direct(isa.SFRS["DPL"], "DPL")
DPH = Direct(isa.SFRS["DPH"], "DPH")


@dataclass(frozen=True, slots=True)
class Bit:
    """A bit address, ``/bit`` when ``negated``; ``name`` is how it is shown (``ACC.3``)."""

    address: int
    name: str | None = None
    negated: bool = False

    def text(self) -> str:
        return ("/" if self.negated else "") + (self.name or hex_number(self.address))

    def parsed(self, column: int) -> ParsedOperand:
        shape = Shape.NOT_BIT if self.negated else Shape.VALUE
        start = column + self.negated
        return _value(shape, column, self.text(), Number(start, 1, self.address))


def acc_bit(bit: int) -> Bit:
    return Bit(isa.SFRS["ACC"] + bit, f"ACC.{bit}")


@dataclass(frozen=True, slots=True)
class Imm:
    """``#value``: a number, or the value of a symbol given by its name."""

    value: int | str

    def text(self) -> str:
        return "#" + (hex_number(self.value) if isinstance(self.value, int) else self.value)

    def parsed(self, column: int) -> ParsedOperand:
        value = self.value
        expr: Expr = (
            Number(column + 1, 1, value)
            if isinstance(value, int)
            else SymbolRef(column + 1, len(value), value)
        )
        return _value(Shape.IMMEDIATE, column, self.text(), expr)


@dataclass(frozen=True, slots=True)
class Ref:
    """A symbol used as an address: a label, a block's entry, a firmware entry point."""

    symbol: str

    def text(self) -> str:
        return self.symbol

    def parsed(self, column: int) -> ParsedOperand:
        return _value(
            Shape.VALUE, column, self.symbol, SymbolRef(column, len(self.symbol), self.symbol)
        )


def _value(shape: Shape, column: int, text: str, expr: Expr) -> ParsedOperand:
    return ParsedOperand(shape, column, len(text), expr=expr, text=text)


Operand = Reg | Direct | Bit | Imm | Ref


# ----------------------------------------------------------------------- items


@lru_cache(maxsize=8192)
def _instruction_line(mnemonic: str, operands: tuple[Operand, ...]) -> tuple[str, ParsedLine]:
    """An instruction's text and parsed form (both immutable: a program repeats most of
    its instructions, and each is built once)."""
    text = _INDENT + mnemonic
    column = len(text) + 2
    parsed = []
    for i, operand in enumerate(operands):
        written = operand.text()
        text += ("," if i else " ") + written
        parsed.append(operand.parsed(column))
        column += len(written) + 1
    return text, ParsedLine(None, Instruction(mnemonic, len(_INDENT) + 1, tuple(parsed)))


@dataclass(frozen=True, slots=True)
class Insn:
    """One instruction and the IL span it implements (None: entry, helpers, implicit BE)."""

    mnemonic: str
    operands: tuple[Operand, ...] = ()
    span: Span | None = None

    def line(self) -> tuple[str, ParsedLine]:
        """Its text and its parsed form."""
        return _instruction_line(self.mnemonic, self.operands)

    def is_(self, mnemonic: str, *operands: Operand) -> bool:
        return self.mnemonic == mnemonic and self.operands == operands


@dataclass(frozen=True, slots=True)
class Mark:
    """A label: a place other code refers to."""

    name: str
    span: Span | None = None


@dataclass(frozen=True, slots=True)
class Branch:
    """``JC target``, whose form the stream chooses: short, or ``JNC skip / LJMP target``.

    ``number`` names its skip label in the long form."""

    target: str
    number: int
    span: Span | None = None

    def lines(self, long: bool) -> list[tuple[str, ParsedLine]]:
        if not long:
            return [Insn("JC", (Ref(self.target),)).line()]
        skip = f"?J{self.number}"
        return [
            Insn("JNC", (Ref(skip),)).line(),
            Insn("LJMP", (Ref(self.target),)).line(),
            (f"{skip}:", ParsedLine(Label(skip, 1), None)),
        ]


@dataclass(frozen=True, slots=True)
class Raw:
    """A line of hand-written assembly (ASM, [ASSEMBLY]), passed on as written."""

    text: str
    span: Span | None
    parsed: ParsedLine


@dataclass(frozen=True, slots=True)
class Comment:
    """A comment line (the listing's symbol values): no code."""

    text: str


@dataclass(frozen=True, slots=True)
class Org:
    """Where the code that follows is placed."""

    address: int


@dataclass(frozen=True, slots=True)
class End:
    """The end of the program."""


Item = Insn | Mark | Branch | Raw | Comment | Org | End


@dataclass(frozen=True, slots=True)
class Line:
    """One line of the generated assembly and the IL span it implements."""

    text: str
    span: Span | None


@dataclass(frozen=True)
class Output:
    """What a stream yields: the assembled code and the lines it was assembled from."""

    assembly: Assembly
    lines: tuple[Line, ...]
    #: upper-case names of every symbol the code refers to, hand-written lines included
    references: frozenset[str]
    #: the assembler's warnings, those on generated lines at the IL line they concern
    diagnostics: tuple[Diagnostic, ...]


# ----------------------------------------------------------------------- the stream


@dataclass
class OutputStream:
    """The generated program as objects, in order, with the peephole rules applied as
    they are appended."""

    items: list[Item] = field(default_factory=list)
    _branches: int = 0

    def emit(self, insn: Insn) -> None:
        """Append an instruction, with the peephole rules that need only the one before:
        a ``CLR C`` overwritten by ``MOV C,bit`` goes, and so does a second ``RET``."""
        last = self.items[-1] if self.items else None
        if isinstance(last, Insn):
            if last.is_("CLR", C) and insn.mnemonic == "MOV" and insn.operands[0] == C:
                self.items.pop()
            elif last.is_("RET") and insn.is_("RET"):
                return
        self.items.append(insn)

    def label(self, name: str, span: Span | None) -> None:
        """Place a label; a ``LJMP`` to it just before is dropped."""
        last = self.items[-1] if self.items else None
        if isinstance(last, Insn) and last.is_("LJMP", Ref(name)):
            self.items.pop()
        self.items.append(Mark(name, span))

    def branch(self, target: str, span: Span | None) -> None:
        """A jump to ``target`` if the carry is set, relaxed when the program is laid out."""
        self._branches += 1
        self.items.append(Branch(target, self._branches, span))

    def raw(self, text: str, span: Span | None) -> None:
        self.items.append(Raw(text, span, parse_line(text)))

    def add(self, item: Comment | Org | End) -> None:
        self.items.append(item)

    # --------------------------------------------------------------- output

    def references(self) -> frozenset[str]:
        """Every symbol the code refers to, by its upper-case name (as the assembler
        knows symbols), from the objects and from the hand-written lines."""
        names: set[str] = set()
        for item in self.items:
            if isinstance(item, Insn):
                for operand in item.operands:
                    if isinstance(operand, Ref):
                        names.add(operand.symbol.upper())
                    elif isinstance(operand, Imm) and isinstance(operand.value, str):
                        names.add(operand.value.upper())
            elif isinstance(item, Branch):
                names.add(item.target.upper())
            elif isinstance(item, Raw):
                names.update(name.upper() for name in referenced_symbols(item.parsed))
        return frozenset(names)

    def relax(self, predefined: Mapping[str, int]) -> frozenset[int]:
        """The branches (by item index) that must take the long form."""
        short = [_lines_of(item, long=False) for item in self.items]
        return self._relax(short, predefined)[0]

    def assemble(self, predefined: Mapping[str, int]) -> Output:
        """Lay the program out, choose the branches' forms, and assemble it.

        Raises ``DiagnosticError`` with the assembler's findings, those on generated lines
        reported at the IL line that produced them."""
        short = [_lines_of(item, long=False) for item in self.items]
        _, layout, lines = self._relax(short, predefined)
        try:
            assembly = layout.assemble()
        except DiagnosticError as exc:
            raise DiagnosticError(map_back(exc.diagnostics, lines)) from None
        warnings = tuple(map_back(assembly.diagnostics, lines))
        return Output(assembly, tuple(lines), self.references(), warnings)

    def _relax(
        self, short: list[_Lines], predefined: Mapping[str, int]
    ) -> tuple[frozenset[int], Layout, list[Line]]:
        """Grow branches round by round while the layout puts the target of a short one
        out of its reach; the long ones, the last layout (which no branch changed), and
        its lines."""
        long: frozenset[int] = frozenset()
        while True:
            source, lines, owners = self._source(short, long)
            layout = locate(source, predefined=predefined)
            first_line: dict[int, int] = {}
            for number, owner in enumerate(owners[: len(layout.addresses)]):
                first_line.setdefault(owner, number)
            grow = set()
            for index, item in enumerate(self.items):
                if not isinstance(item, Branch) or index in long or index not in first_line:
                    continue
                target = layout.labels.get(item.target.upper())
                if target is None:
                    continue  # undefined: the assembly reports it
                after = layout.addresses[first_line[index]] + _SHORT_JUMP
                if (target - after + 0x8000) % 0x10000 - 0x8000 not in _REACH:
                    grow.add(index)
            if not grow:
                return long, layout, lines
            long |= grow

    def _source(
        self, short: list[_Lines], long: frozenset[int]
    ) -> tuple[ParsedSource, list[Line], list[int]]:
        """The program's source for the assembler, its lines with their spans, and the
        index of the item each line comes from; the branches in ``long`` take the long
        form, everything else is as in ``short``."""
        texts: list[str] = []
        parsed: list[ParsedLine] = []
        lines: list[Line] = []
        owners: list[int] = []
        for index, (item, item_lines) in enumerate(zip(self.items, short, strict=True)):
            if index in long:
                item_lines = _lines_of(item, long=True)
            span = _span(item)
            for text, line in item_lines:
                texts.append(text)
                parsed.append(line)
                lines.append(Line(text, span))
                owners.append(index)
        text = "".join(f"{text}\n" for text in texts)
        source = SourceText(GENERATED, text, text.encode("utf-8"))
        return ParsedSource(source, parsed), lines, owners


_Lines = list[tuple[str, ParsedLine]]


def _lines_of(item: Item, *, long: bool) -> _Lines:
    """The lines an item is written as, each with its parsed form."""
    match item:
        case Insn():
            return [item.line()]
        case Mark(name=name):
            return [(f"{name}:", ParsedLine(Label(name, 1), None))]
        case Branch():
            return item.lines(long)
        case Raw(text=text, parsed=parsed):
            return [(text, parsed)]
        case Comment(text=text):
            return [(f"; {text}", ParsedLine(None, None))]
        case Org(address=address):
            value = Number(len(_INDENT) + 5, 1, address)
            org = Directive("ORG", len(_INDENT) + 1, (value,))
            return [(f"{_INDENT}ORG {hex_number(address)}", ParsedLine(None, org))]
        case End():
            return [(f"{_INDENT}END", ParsedLine(None, Directive("END", len(_INDENT) + 1)))]
        case _:
            assert_never(item)


def _span(item: Item) -> Span | None:
    """The IL span an item implements; None for what no IL line asked for."""
    return item.span if isinstance(item, Insn | Mark | Branch | Raw) else None


def map_back(diagnostics: Sequence[Diagnostic], lines: Sequence[Line]) -> list[Diagnostic]:
    """Assembler findings on generated lines, reported at the IL line that produced them."""
    mapped: list[Diagnostic] = []
    for d in diagnostics:
        span = d.span
        if span is not None and span.file == GENERATED and 0 < span.line <= len(lines):
            line = lines[span.line - 1]
            message = f"{d.message} (in the assembly line '{line.text.strip()}')"
            mapped.append(Diagnostic(d.severity, d.code, message, line.span))
        else:
            mapped.append(d)
    return mapped
