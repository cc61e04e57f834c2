"""How a program uses each operand: the facts the analyses (``il.wiring``, ``il.logic``)
judge, gathered in one walk over the checked program.

An editor's reference index (``il.references``) answers "where is this name?" with
names as text and places as spans. The analyses ask other questions, of every check of
every program: which slave and data bit does this operand address, which bytes of the
flags does it cover, does this instruction start the timer or stop it, does PARAM write
F 127, is there assembler code that may touch anything? So each use carries a ``Key``,
what it is a use of, and the instruction (its "mark"), and the walk is kept lean: the
analyses run on every ``asictl check``.

The operands and what each statement does with them come from ``ast.operands``. A key is
the memory an operand names, whatever width a statement takes of it (``S T 1`` and
``L T 1`` are one timer) and however a variable's name is spelled; labels and blocks
have keys too. The same memory written two ways is two keys (``F 11.0`` and ``FY 11``),
as a programmer reads them; ``ast.flag_bytes`` relates them.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from enum import StrEnum
from typing import NamedTuple, assert_never

from asictl.diagnostics import Span
from asictl.il import ast
from asictl.il.ast import key
from asictl.il.loader import Program
from asictl.runtime.firmware import FIRMWARE_BLOCKS


class Name(StrEnum):
    """What else a program names: its labels and the blocks it declares and calls."""

    LABEL = "label"
    BLOCK = "block"


class Key(NamedTuple):
    """What a use is of. For an operand: its kind, a variable's ``key()`` name, the address
    and bit of ``ast.Operand``; for a label or block its ``key()`` name (and a label's file
    in ``scope``). A named tuple: a program has thousands, made, hashed and sorted on every
    check."""

    kind: ast.OperandKind | Name
    name: str = ""
    address: int = -1
    bit: int = -1
    scope: str = ""

    @classmethod
    def of(cls, operand: ast.Operand) -> Key:
        if operand.kind is ast.OperandKind.VAR:
            return cls(operand.kind, key(operand.name), operand.address, operand.bit)
        return cls(operand.kind, "", operand.address, operand.bit)

    def text(self, spelling: str = "") -> str:
        """As IL writes it; ``spelling`` is a name as the source spells it."""
        name = spelling or self.name
        kind = self.kind
        if isinstance(kind, Name) or (kind is ast.OperandKind.VAR and self.address < 0):
            return name
        return str(ast.Operand(kind, self.address, self.bit, name=name))


class Access(StrEnum):
    """How a place uses an operand."""

    DEFINE = "defined"  # a declaration or a label
    READ = "read"
    WRITE = "write"
    USE = "used"  # a jump to a label, a call of a block


#: A count reads its counter only to write it back: for the analyses it sets the counter
#: (one that is only counted is set and never read).
_ACCESS = {
    ast.Access.READ: Access.READ, ast.Access.WRITE: Access.WRITE,
    ast.Access.READ_WRITE: Access.WRITE,
}


class Use(NamedTuple):
    """One place: ``mark`` is the instruction (see ``mark``)."""

    operand: Key
    access: Access
    mark: str
    span: Span


@dataclass
class Usage:
    """Every use of an operand in a program, in source order (main file, then the blocks)."""

    uses: list[Use] = field(default_factory=list)
    #: (kind, key(name)) -> the name as first written, for variables, labels and blocks
    spellings: dict[tuple[ast.OperandKind | Name, str], str] = field(default_factory=dict)
    #: whether the program has code the index cannot see into (ASM, [ASSEMBLY])
    has_assembly: bool = False

    def by_operand(self) -> dict[Key, list[Use]]:
        table: dict[Key, list[Use]] = {}
        for use in self.uses:
            table.setdefault(use.operand, []).append(use)
        return dict(sorted(table.items()))

    def of_kind(self, *kinds: ast.OperandKind | Name) -> Iterator[Use]:
        wanted = set(kinds)
        return (r for r in self.uses if r.operand.kind in wanted)

    def text(self, operand: Key) -> str:
        if is_firmware_block(operand):
            return FIRMWARE_BLOCKS[operand.name].name
        return operand.text(self.spellings.get((operand.kind, operand.name), ""))


def mark(node: ast.Statement | ast.GatingLine | ast.Declaration, *, written: bool) -> str:
    """The instruction at a place, as the cross-reference shows it: ``A AN O ON = S R L
    T CU CD STP JU JC``, ``G`` for a [GATING] source (``=`` for its target), ``:`` for a
    label, ``PARAM`` for its answer, ``BYTE``/``TIMER``/``COUNTER``/``FB`` for [DECL]."""
    match node:
        case ast.Logic() | ast.Store() | ast.Count():
            return node.op  # (a StrEnum: its own text)
        case ast.Load():
            return "L"
        case ast.Transfer():
            return "T"
        case ast.Jump(conditional=conditional) | ast.CallFB(conditional=conditional):
            return "JC" if conditional else "JU"
        case ast.Label():
            return ":"
        case ast.GatingLine():
            return "=" if written else "G"
        case ast.Param():
            return "PARAM"
        case ast.VarDecl():
            return "BYTE"
        case ast.TimerDecl():
            return "TIMER"
        case ast.CounterDecl():
            return "COUNTER"
        case ast.FBDecl():
            return "FB"
        case (ast.Not() | ast.Arith() | ast.Compare() | ast.SegmentEnd() | ast.BlockEnd()
              | ast.Asm()):
            return node.to_source()
        case _:
            assert_never(node)


class _Builder:
    def __init__(self, index: Usage) -> None:
        self.index = index

    def add(self, operand: Key, access: Access, node: ast.Statement | ast.Declaration,
            span: Span | None, spelling: str = "") -> None:
        if span is None:
            return
        if spelling:
            self.index.spellings.setdefault((operand.kind, operand.name), spelling)
        written = access is Access.WRITE
        self.index.uses.append(Use(operand, access, mark(node, written=written), span))

    def module(self, module: ast.Module) -> None:
        index = self.index
        for section in module.sections:
            if isinstance(section, ast.DeclSection):
                for decl in section.declarations:
                    self.declaration(decl)
            elif isinstance(section, ast.AssemblySection):
                index.has_assembly = True
        uses, spellings = index.uses, index.spellings
        constants, variable, gating_line = ast.CONSTANTS, ast.OperandKind.VAR, ast.GatingLine
        for node in module.code():
            found = ast.operands(node)
            if not found:
                if isinstance(node, ast.Label | ast.Jump | ast.CallFB | ast.Asm):
                    self.name(node, module.file)
                continue
            gating = isinstance(node, gating_line)  # the only node with marks per operand
            shown = "" if gating else mark(node, written=False)
            for operand, used in found:
                span, kind = operand.span, operand.kind
                if span is None or kind in constants:
                    continue
                if kind is variable:
                    name = key(operand.name)
                    spellings.setdefault((kind, name), operand.name)
                    what = Key(kind, name, operand.address, operand.bit)
                else:
                    what = Key(kind, "", operand.address, operand.bit)
                access = _ACCESS[used]
                if gating:
                    shown = mark(node, written=access is Access.WRITE)
                uses.append(Use(what, access, shown, span))

    def declaration(self, decl: ast.Declaration) -> None:
        match decl:
            case ast.VarDecl(name=name, span=span):
                self.add(Key(ast.OperandKind.VAR, key(name)), Access.DEFINE, decl, span, name)
            case ast.TimerDecl(number=number, span=span):
                self.add(Key(ast.OperandKind.T, address=number), Access.DEFINE, decl, span)
            case ast.CounterDecl(number=number, span=span):
                self.add(Key(ast.OperandKind.C, address=number), Access.DEFINE, decl, span)
            case ast.FBDecl(name=name, span=span):
                self.add(Key(Name.BLOCK, key(name)), Access.DEFINE, decl, span, name)
            case _:
                assert_never(decl)

    def name(self, statement: ast.Label | ast.Jump | ast.CallFB | ast.Asm, file: str) -> None:
        match statement:
            case ast.Label(name=name, span=span):
                self.add(Key(Name.LABEL, key(name), scope=file), Access.DEFINE, statement, span,
                         name)
            case ast.Jump(label=label, span=span):
                self.add(Key(Name.LABEL, key(label), scope=file), Access.USE, statement, span,
                         label)
            case ast.CallFB(name=name, span=span):
                self.add(Key(Name.BLOCK, key(name)), Access.USE, statement, span, name)
            case ast.Asm():
                self.index.has_assembly = True
            case _:
                assert_never(statement)


def usage_of(program: Program) -> Usage:
    """Every use of an operand in the main file and in every block it calls."""
    index = Usage()
    builder = _Builder(index)
    for module in program.modules():
        builder.module(module)
    return index


def is_firmware_block(operand: Key) -> bool:
    return operand.kind is Name.BLOCK and operand.name in FIRMWARE_BLOCKS
