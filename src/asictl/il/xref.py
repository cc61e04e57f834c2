"""The reference index: every place a program reads, writes, defines or uses each operand.

One walk over the checked program gives the cross-reference (``asictl xref``, the
listing's cross-reference) and the facts the analyses need (is a flag ever written, a
timer ever read, a label ever jumped to, which slave an operand addresses), so each
analysis asks the index instead of walking the tree again.

An operand is a ``Symbol``: the same memory written two ways is two symbols (``F 11.0``
and ``FY 11``), as a programmer reads them; ``overlapping_flag_bytes`` relates them.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from enum import IntEnum, StrEnum
from typing import NamedTuple

from asictl.diagnostics import Span
from asictl.il import ast
from asictl.il.ast import key
from asictl.il.language import PARAM_FLAG
from asictl.il.loader import Program
from asictl.runtime.firmware import FIRMWARE_BLOCKS


class SymbolKind(IntEnum):
    """What an operand is; the order is the order of a cross-reference."""

    INPUT = 0
    OLD_INPUT = 1
    OUTPUT = 2
    FLAG = 3
    INPUT_BYTE = 4
    OLD_INPUT_BYTE = 5
    OUTPUT_BYTE = 6
    FLAG_BYTE = 7
    FLAG_WORD = 8
    PSEG = 9
    TIMER = 10
    COUNTER = 11
    VARIABLE = 12
    LABEL = 13
    BLOCK = 14


_BIT_KINDS = {
    ast.BitArea.I: SymbolKind.INPUT, ast.BitArea.I2: SymbolKind.OLD_INPUT,
    ast.BitArea.Q: SymbolKind.OUTPUT, ast.BitArea.F: SymbolKind.FLAG,
}
_BYTE_KINDS = {
    ast.ByteArea.IB: SymbolKind.INPUT_BYTE, ast.ByteArea.I2B: SymbolKind.OLD_INPUT_BYTE,
    ast.ByteArea.QB: SymbolKind.OUTPUT_BYTE, ast.ByteArea.FY: SymbolKind.FLAG_BYTE,
    ast.ByteArea.PSEG: SymbolKind.PSEG,
}
_MARKS = {
    SymbolKind.INPUT: "I", SymbolKind.OLD_INPUT: "I2", SymbolKind.OUTPUT: "Q",
    SymbolKind.FLAG: "F", SymbolKind.INPUT_BYTE: "IB", SymbolKind.OLD_INPUT_BYTE: "I2B",
    SymbolKind.OUTPUT_BYTE: "QB", SymbolKind.FLAG_BYTE: "FY", SymbolKind.FLAG_WORD: "FW",
    SymbolKind.PSEG: "PSeg", SymbolKind.TIMER: "T", SymbolKind.COUNTER: "C",
}
#: The operands that address a slave's data: (kind, is a byte of two slaves).
SLAVE_KINDS = {
    SymbolKind.INPUT: False, SymbolKind.OLD_INPUT: False, SymbolKind.OUTPUT: False,
    SymbolKind.INPUT_BYTE: True, SymbolKind.OLD_INPUT_BYTE: True, SymbolKind.OUTPUT_BYTE: True,
}


class Symbol(NamedTuple):
    """One operand, label or block. ``name`` is ``key()`` of a variable, label or block;
    ``number`` the slave, byte, word, timer or counter number or a variable's byte offset;
    ``bit`` the bit (-1 for none); ``scope`` the file a label belongs to. (A named tuple:
    a program has thousands, made, hashed and sorted on every check.)"""

    kind: SymbolKind
    name: str = ""
    number: int = -1
    bit: int = -1
    scope: str = ""

    def text(self, spelling: str = "") -> str:
        """The operand as IL writes it; ``spelling`` is a name as the source spells it."""
        name = spelling or self.name
        if self.kind in (SymbolKind.LABEL, SymbolKind.BLOCK):
            return name
        if self.kind is SymbolKind.VARIABLE:
            if self.number < 0:
                return name
            return f"{name} {self.number}" + (f".{self.bit}" if self.bit >= 0 else "")
        text = f"{_MARKS[self.kind]} {self.number}"
        return f"{text}.{self.bit}" if self.bit >= 0 else text


class Access(StrEnum):
    """How a place refers to a symbol."""

    DEFINE = "defined"  # a declaration or a label
    READ = "read"
    WRITE = "write"
    USE = "used"  # a jump to a label, a call of a block


class Reference(NamedTuple):
    """One place: ``mark`` is the instruction (``A``, ``=``, ``S``, ``L``, ``T``, ``CU``,
    ``JC``, ``:`` for a label, ``G`` for a [GATING] source, ``PARAM`` for its answer)."""

    symbol: Symbol
    access: Access
    mark: str
    span: Span


@dataclass
class ReferenceIndex:
    """Every reference of a program, in source order (main file first, then the blocks)."""

    references: list[Reference] = field(default_factory=list)
    #: (kind, key(name)) -> the name as first written, for variables, labels and blocks
    spellings: dict[tuple[SymbolKind, str], str] = field(default_factory=dict)
    #: the files in program order (main first), for sorting references
    files: list[str] = field(default_factory=list)
    #: whether the program has code the index cannot see into (ASM, [ASSEMBLY])
    has_assembly: bool = False

    def by_symbol(self) -> dict[Symbol, list[Reference]]:
        table: dict[Symbol, list[Reference]] = {}
        for reference in self.references:
            table.setdefault(reference.symbol, []).append(reference)
        return dict(sorted(table.items()))

    def of_kind(self, *kinds: SymbolKind) -> Iterator[Reference]:
        wanted = set(kinds)
        return (r for r in self.references if r.symbol.kind in wanted)

    def text(self, symbol: Symbol) -> str:
        if is_firmware_block(symbol):
            return FIRMWARE_BLOCKS[symbol.name].name
        return symbol.text(self.spellings.get((symbol.kind, symbol.name), ""))


def symbol_of(operand: object) -> Symbol | None:
    """The symbol an operand refers to (None for constants)."""
    if isinstance(operand, ast.ImageBit):
        return Symbol(_BIT_KINDS[operand.area], "", operand.address, operand.bit)
    if isinstance(operand, ast.ImageByte):
        return Symbol(_BYTE_KINDS[operand.area], "", operand.number)
    if isinstance(operand, ast.TimerRef):
        return Symbol(SymbolKind.TIMER, "", operand.number)
    if isinstance(operand, ast.CounterRef):
        return Symbol(SymbolKind.COUNTER, "", operand.number)
    if isinstance(operand, ast.FlagWord):
        return Symbol(SymbolKind.FLAG_WORD, "", operand.number)
    if isinstance(operand, ast.VarBit):
        return Symbol(SymbolKind.VARIABLE, key(operand.name), operand.offset, operand.bit)
    if isinstance(operand, ast.VarByte):
        return Symbol(SymbolKind.VARIABLE, key(operand.name), operand.offset)
    return None


def flag_bytes(symbol: Symbol) -> range:
    """The flag bytes a flag operand covers (FW n is FY n and FY n+1); empty for others."""
    if symbol.kind in (SymbolKind.FLAG, SymbolKind.FLAG_BYTE):
        return range(symbol.number, symbol.number + 1)
    if symbol.kind is SymbolKind.FLAG_WORD:
        return range(symbol.number, symbol.number + 2)
    return range(0)


def slaves_of(symbol: Symbol) -> tuple[int, ...]:
    """The slaves whose data an I/I2/Q operand addresses (two for a byte)."""
    two = SLAVE_KINDS.get(symbol.kind)
    if two is None:
        return ()
    return (symbol.number, symbol.number + 1) if two else (symbol.number,)


class _Builder:
    def __init__(self, index: ReferenceIndex) -> None:
        self.index = index

    def add(self, symbol: Symbol, access: Access, mark: str, span: Span | None,
            spelling: str = "") -> None:
        if span is None:
            return
        if spelling:
            self.index.spellings.setdefault((symbol.kind, symbol.name), spelling)
        self.index.references.append(Reference(symbol, access, mark, span))

    def operand(self, operand: object, access: Access, mark: str) -> None:
        symbol = symbol_of(operand)
        span = getattr(operand, "span", None)
        if symbol is None or span is None:
            return
        if symbol.kind is SymbolKind.VARIABLE:
            self.index.spellings.setdefault(
                (symbol.kind, symbol.name), getattr(operand, "name", ""))
        self.index.references.append(Reference(symbol, access, mark, span))

    def module(self, module: ast.Module) -> None:
        for section in module.sections:
            match section:
                case ast.DeclSection():
                    self.declarations(section)
                case ast.ProgramSection():
                    for statement in section.statements:
                        self.statement(statement, module.file)
                case ast.GatingSection():
                    for line in section.lines:
                        self.operand(line.target, Access.WRITE, "=")
                        for term in line.terms:
                            self.operand(term.operand, Access.READ, "G")
                case ast.AssemblySection():
                    self.index.has_assembly = True

    def declarations(self, section: ast.DeclSection) -> None:
        for decl in section.declarations:
            match decl:
                case ast.VarDecl(name=name, span=span):
                    self.add(Symbol(SymbolKind.VARIABLE, name=key(name)), Access.DEFINE,
                             "BYTE", span, name)
                case ast.TimerDecl(number=number, span=span):
                    self.add(Symbol(SymbolKind.TIMER, number=number), Access.DEFINE, "TIMER",
                             span)
                case ast.CounterDecl(number=number, span=span):
                    self.add(Symbol(SymbolKind.COUNTER, number=number), Access.DEFINE,
                             "COUNTER", span)
                case ast.FBDecl(name=name, span=span):
                    self.add(Symbol(SymbolKind.BLOCK, name=key(name)), Access.DEFINE, "FB",
                             span, name)

    def statement(self, statement: ast.Statement, file: str) -> None:
        # the operand instructions first: they are nearly all of a program
        if isinstance(statement, ast.Logic):
            self.operand(statement.operand, Access.READ, statement.op.value)
        elif isinstance(statement, ast.Store):
            self.operand(statement.operand, Access.WRITE, statement.op.value)
        elif isinstance(statement, ast.Load):
            self.operand(statement.operand, Access.READ, "L")
        elif isinstance(statement, ast.Transfer):
            self.operand(statement.operand, Access.WRITE, "T")
        elif isinstance(statement, ast.Count):
            self.operand(statement.counter, Access.WRITE, statement.op.value)
        elif isinstance(statement, ast.Label):
            self.add(Symbol(SymbolKind.LABEL, key(statement.name), scope=file), Access.DEFINE,
                     ":", statement.span, statement.name)
        elif isinstance(statement, ast.Jump):
            self.add(Symbol(SymbolKind.LABEL, key(statement.label), scope=file), Access.USE,
                     "JC" if statement.conditional else "JU", statement.span, statement.label)
        elif isinstance(statement, ast.CallFB):
            self.add(Symbol(SymbolKind.BLOCK, key(statement.name)), Access.USE,
                     "JC" if statement.conditional else "JU", statement.span, statement.name)
        elif isinstance(statement, ast.Param):
            self.add(Symbol(SymbolKind.FLAG_BYTE, "", PARAM_FLAG), Access.WRITE, "PARAM",
                     statement.span)
        elif isinstance(statement, ast.Asm):
            self.index.has_assembly = True


def reference_index(program: Program) -> ReferenceIndex:
    """Every reference of the main file and of every block it calls."""
    index = ReferenceIndex(files=list(dict.fromkeys(m.file for m in program.modules())))
    builder = _Builder(index)
    for module in program.modules():
        builder.module(module)
    return index


def is_firmware_block(symbol: Symbol) -> bool:
    return symbol.kind is SymbolKind.BLOCK and symbol.name in FIRMWARE_BLOCKS
