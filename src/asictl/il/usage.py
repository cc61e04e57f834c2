"""How a program uses each operand: the facts the analyses (``il.wiring``, ``il.logic``)
judge, gathered in one walk over the checked program.

An editor's reference index (``il.references``) answers "where is this name?" with
names as text and places as spans. The analyses ask other questions, of every check of
every program: which slave and data bit does this operand address, which bytes of the
flags does it cover, does this instruction start the timer or stop it, does PARAM write
F 127, is there assembler code that may touch anything? So an operand here is a
structured ``Operand`` (kind, number, bit), each use carries the instruction (its
"mark"), and the walk is kept lean: the analyses run on every ``asictl check``.

The same memory written two ways is two operands (``F 11.0`` and ``FY 11``), as a
programmer reads them; ``flag_bytes`` relates them.
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


class OperandKind(IntEnum):
    """What an operand is (labels and blocks too)."""

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
    ast.BitArea.I: OperandKind.INPUT, ast.BitArea.I2: OperandKind.OLD_INPUT,
    ast.BitArea.Q: OperandKind.OUTPUT, ast.BitArea.F: OperandKind.FLAG,
}
_BYTE_KINDS = {
    ast.ByteArea.IB: OperandKind.INPUT_BYTE, ast.ByteArea.I2B: OperandKind.OLD_INPUT_BYTE,
    ast.ByteArea.QB: OperandKind.OUTPUT_BYTE, ast.ByteArea.FY: OperandKind.FLAG_BYTE,
    ast.ByteArea.PSEG: OperandKind.PSEG,
}
_MARKS = {
    OperandKind.INPUT: "I", OperandKind.OLD_INPUT: "I2", OperandKind.OUTPUT: "Q",
    OperandKind.FLAG: "F", OperandKind.INPUT_BYTE: "IB", OperandKind.OLD_INPUT_BYTE: "I2B",
    OperandKind.OUTPUT_BYTE: "QB", OperandKind.FLAG_BYTE: "FY", OperandKind.FLAG_WORD: "FW",
    OperandKind.PSEG: "PSeg", OperandKind.TIMER: "T", OperandKind.COUNTER: "C",
}
#: The operands that address a slave's data: (kind, is a byte of two slaves).
SLAVE_KINDS = {
    OperandKind.INPUT: False, OperandKind.OLD_INPUT: False, OperandKind.OUTPUT: False,
    OperandKind.INPUT_BYTE: True, OperandKind.OLD_INPUT_BYTE: True, OperandKind.OUTPUT_BYTE: True,
}


class Operand(NamedTuple):
    """One operand, label or block. ``name`` is ``key()`` of a variable, label or block;
    ``number`` the slave, byte, word, timer or counter number or a variable's byte offset;
    ``bit`` the bit (-1 for none); ``scope`` the file a label belongs to. (A named tuple:
    a program has thousands, made, hashed and sorted on every check.)"""

    kind: OperandKind
    name: str = ""
    number: int = -1
    bit: int = -1
    scope: str = ""

    def text(self, spelling: str = "") -> str:
        """The operand as IL writes it; ``spelling`` is a name as the source spells it."""
        name = spelling or self.name
        if self.kind in (OperandKind.LABEL, OperandKind.BLOCK):
            return name
        if self.kind is OperandKind.VARIABLE:
            if self.number < 0:
                return name
            return f"{name} {self.number}" + (f".{self.bit}" if self.bit >= 0 else "")
        text = f"{_MARKS[self.kind]} {self.number}"
        return f"{text}.{self.bit}" if self.bit >= 0 else text


class Access(StrEnum):
    """How a place uses an operand."""

    DEFINE = "defined"  # a declaration or a label
    READ = "read"
    WRITE = "write"
    USE = "used"  # a jump to a label, a call of a block


class Use(NamedTuple):
    """One place: ``mark`` is the instruction (``A``, ``=``, ``S``, ``L``, ``T``, ``CU``,
    ``JC``, ``:`` for a label, ``G`` for a [GATING] source, ``PARAM`` for its answer)."""

    operand: Operand
    access: Access
    mark: str
    span: Span


@dataclass
class Usage:
    """Every use of an operand in a program, in source order (main file, then the blocks)."""

    uses: list[Use] = field(default_factory=list)
    #: (kind, key(name)) -> the name as first written, for variables, labels and blocks
    spellings: dict[tuple[OperandKind, str], str] = field(default_factory=dict)
    #: whether the program has code the index cannot see into (ASM, [ASSEMBLY])
    has_assembly: bool = False

    def by_operand(self) -> dict[Operand, list[Use]]:
        table: dict[Operand, list[Use]] = {}
        for use in self.uses:
            table.setdefault(use.operand, []).append(use)
        return dict(sorted(table.items()))

    def of_kind(self, *kinds: OperandKind) -> Iterator[Use]:
        wanted = set(kinds)
        return (r for r in self.uses if r.operand.kind in wanted)

    def text(self, operand: Operand) -> str:
        if is_firmware_block(operand):
            return FIRMWARE_BLOCKS[operand.name].name
        return operand.text(self.spellings.get((operand.kind, operand.name), ""))


def operand_of(operand: object) -> Operand | None:
    """The operand an operand refers to (None for constants)."""
    if isinstance(operand, ast.ImageBit):
        return Operand(_BIT_KINDS[operand.area], "", operand.address, operand.bit)
    if isinstance(operand, ast.ImageByte):
        return Operand(_BYTE_KINDS[operand.area], "", operand.number)
    if isinstance(operand, ast.TimerRef):
        return Operand(OperandKind.TIMER, "", operand.number)
    if isinstance(operand, ast.CounterRef):
        return Operand(OperandKind.COUNTER, "", operand.number)
    if isinstance(operand, ast.FlagWord):
        return Operand(OperandKind.FLAG_WORD, "", operand.number)
    if isinstance(operand, ast.VarBit):
        return Operand(OperandKind.VARIABLE, key(operand.name), operand.offset, operand.bit)
    if isinstance(operand, ast.VarByte):
        return Operand(OperandKind.VARIABLE, key(operand.name), operand.offset)
    return None


def flag_bytes(operand: Operand) -> range:
    """The flag bytes a flag operand covers (FW n is FY n and FY n+1); empty for others."""
    if operand.kind in (OperandKind.FLAG, OperandKind.FLAG_BYTE):
        return range(operand.number, operand.number + 1)
    if operand.kind is OperandKind.FLAG_WORD:
        return range(operand.number, operand.number + 2)
    return range(0)


def slaves_of(operand: Operand) -> tuple[int, ...]:
    """The slaves whose data an I/I2/Q operand addresses (two for a byte)."""
    two = SLAVE_KINDS.get(operand.kind)
    if two is None:
        return ()
    return (operand.number, operand.number + 1) if two else (operand.number,)


class _Builder:
    def __init__(self, index: Usage) -> None:
        self.index = index

    def add(self, operand: Operand, access: Access, mark: str, span: Span | None,
            spelling: str = "") -> None:
        if span is None:
            return
        if spelling:
            self.index.spellings.setdefault((operand.kind, operand.name), spelling)
        self.index.uses.append(Use(operand, access, mark, span))

    def operand(self, node: object, access: Access, mark: str) -> None:
        operand = operand_of(node)
        span = getattr(node, "span", None)
        if operand is None or span is None:
            return
        if operand.kind is OperandKind.VARIABLE:
            self.index.spellings.setdefault(
                (operand.kind, operand.name), getattr(node, "name", ""))
        self.index.uses.append(Use(operand, access, mark, span))

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
                    self.add(Operand(OperandKind.VARIABLE, name=key(name)), Access.DEFINE,
                             "BYTE", span, name)
                case ast.TimerDecl(number=number, span=span):
                    self.add(Operand(OperandKind.TIMER, number=number), Access.DEFINE, "TIMER",
                             span)
                case ast.CounterDecl(number=number, span=span):
                    self.add(Operand(OperandKind.COUNTER, number=number), Access.DEFINE,
                             "COUNTER", span)
                case ast.FBDecl(name=name, span=span):
                    self.add(Operand(OperandKind.BLOCK, name=key(name)), Access.DEFINE, "FB",
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
            self.add(Operand(OperandKind.LABEL, key(statement.name), scope=file), Access.DEFINE,
                     ":", statement.span, statement.name)
        elif isinstance(statement, ast.Jump):
            self.add(Operand(OperandKind.LABEL, key(statement.label), scope=file), Access.USE,
                     "JC" if statement.conditional else "JU", statement.span, statement.label)
        elif isinstance(statement, ast.CallFB):
            self.add(Operand(OperandKind.BLOCK, key(statement.name)), Access.USE,
                     "JC" if statement.conditional else "JU", statement.span, statement.name)
        elif isinstance(statement, ast.Param):
            self.add(Operand(OperandKind.FLAG_BYTE, "", PARAM_FLAG), Access.WRITE, "PARAM",
                     statement.span)
        elif isinstance(statement, ast.Asm):
            self.index.has_assembly = True


def usage_of(program: Program) -> Usage:
    """Every use of an operand in the main file and in every block it calls."""
    index = Usage()
    builder = _Builder(index)
    for module in program.modules():
        builder.module(module)
    return index


def is_firmware_block(operand: Operand) -> bool:
    return operand.kind is OperandKind.BLOCK and operand.name in FIRMWARE_BLOCKS
