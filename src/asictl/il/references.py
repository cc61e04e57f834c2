"""Where each name and operand of a program is defined, read and written.

One index serves every tool that navigates a program: an editor's go to definition and
find references, and a cross-reference listing. It is built from the AST alone (every
node carries its span), over the main file and every block file it calls, so the places
it gives are exactly the ones the checks and the compiler see.

A *symbol* is what a place refers to: a label (its scope is the file: labels are local to
the main program or one block), a function block, a declared variable, a timer, a counter,
an AS-i slave, or an exact image operand (``I 4.0``, ``FY 10``). One operand can refer to
several symbols: ``I 4.0`` is the operand ``I 4.0`` and slave 4, ``IB 4`` is slaves 4 and 5.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterator
from dataclasses import dataclass, field
from enum import StrEnum
from typing import assert_never

from asictl.diagnostics import Span
from asictl.il import ast
from asictl.il.ast import key
from asictl.il.loader import Program


class SymbolKind(StrEnum):
    """In order of precedence when several symbols share a place (see ``ReferenceIndex.at``)."""

    LABEL = "label"
    BLOCK = "function block"
    VARIABLE = "variable"
    TIMER = "timer"
    COUNTER = "counter"
    OPERAND = "operand"
    SLAVE = "slave"


_PRECEDENCE = {kind: rank for rank, kind in enumerate(SymbolKind)}


class Role(StrEnum):
    #: where it is defined: a label, a [SETUP] line, a block's own file
    DEFINE = "define"
    #: where [DECL] declares it
    DECLARE = "declare"
    READ = "read"
    WRITE = "write"
    #: a jump to a label, a call of a block, a KP constant naming a slave
    USE = "use"


@dataclass(frozen=True, order=True)
class Symbol:
    kind: SymbolKind
    #: the canonical name: case-folded names, the slave address, ``I 4.0`` for operands
    name: str
    #: the file a label belongs to; empty for program-wide symbols
    scope: str = ""


@dataclass(frozen=True)
class Occurrence:
    symbol: Symbol
    span: Span
    role: Role
    #: the statement, line or declaration the occurrence is part of (for hover texts);
    #: None for a block's own file
    node: ast.BodyNode | None = field(compare=False, repr=False, default=None)

    def covers(self, line: int, column: int) -> bool:
        """Whether the 1-based position lies on the span (its end included, for a cursor
        standing just after a word)."""
        s = self.span
        return s.line == line and s.column <= column <= s.column + s.length


@dataclass
class ReferenceIndex:
    """Every occurrence of every symbol, in source order per file."""

    occurrences: list[Occurrence] = field(default_factory=list)
    by_symbol: dict[Symbol, list[Occurrence]] = field(default_factory=lambda: defaultdict(list))

    def add(
        self, symbol: Symbol, span: Span | None, role: Role, node: ast.BodyNode | None = None
    ) -> None:
        if span is None:
            return
        occurrence = Occurrence(symbol, span, role, node)
        self.occurrences.append(occurrence)
        self.by_symbol[symbol].append(occurrence)

    def of(self, symbol: Symbol) -> list[Occurrence]:
        """Every occurrence of ``symbol``, definitions included, in source order."""
        return sorted(self.by_symbol.get(symbol, []), key=lambda o: o.span)

    def definitions(self, symbol: Symbol) -> list[Occurrence]:
        """Where ``symbol`` is defined; failing that, where it is declared."""
        found = self.by_symbol.get(symbol, [])
        for role in (Role.DEFINE, Role.DECLARE):
            places = [o for o in found if o.role is role]
            if places:
                return sorted(places, key=lambda o: o.span)
        return []

    def at(self, file: str, line: int, column: int) -> list[Occurrence]:
        """The occurrences at a position, the most specific first: the narrowest span, and
        on one span the first kind of ``SymbolKind`` (the operand before its slave)."""
        found = [o for o in self.occurrences if o.span.file == file and o.covers(line, column)]
        return sorted(found, key=lambda o: (o.span.length, _PRECEDENCE[o.symbol.kind]))

    def symbols(self, kind: SymbolKind) -> list[Symbol]:
        return sorted(s for s in self.by_symbol if s.kind is kind)


def build_index(program: Program) -> ReferenceIndex:
    """The index of a loaded program: the main module and every block it reaches."""
    index = ReferenceIndex()
    for name, module in program.blocks.items():
        if module.sections:
            index.add(Symbol(SymbolKind.BLOCK, name), Span(module.file, 1, 1, 0), Role.DEFINE)
    for module in program.modules():
        index_module(module, index)
    return index


def index_module(module: ast.Module, index: ReferenceIndex) -> None:
    """Add one file's occurrences to ``index``."""
    for section in module.sections:
        if isinstance(section, ast.SetupSection):
            for slave in section.slaves:
                index.add(_slave(slave.address), slave.span, Role.DEFINE, slave)
        elif isinstance(section, ast.DeclSection):
            for decl in section.declarations:
                _declaration(decl, index)
    for node in module.code():
        if isinstance(node, ast.Label | ast.Jump | ast.CallFB):
            _name(node, module.file, index)
        for operand, access in ast.operands(node):
            role = Role.READ if access is ast.Access.READ else Role.WRITE  # a count: a write
            for symbol in operand_symbols(operand):
                use = Role.USE if operand.kind is ast.OperandKind.KP else role
                index.add(symbol, operand.span, use, node)


def _slave(address: int) -> Symbol:
    return Symbol(SymbolKind.SLAVE, str(address))


def _head(span: Span | None, name: str) -> Span | None:
    """The span of ``name`` at the start of ``span``."""
    return None if span is None else Span(span.file, span.line, span.column, len(name))


def _tail(span: Span | None, name: str) -> Span | None:
    """The span of ``name`` at the end of ``span`` (a jump's label, a call's block)."""
    if span is None:
        return None
    return Span(span.file, span.line, span.column + span.length - len(name), len(name))


def _declaration(decl: ast.Declaration, index: ReferenceIndex) -> None:
    match decl:
        case ast.VarDecl(name=name, span=span):
            index.add(Symbol(SymbolKind.VARIABLE, key(name)), _head(span, name), Role.DECLARE,
                      decl)
        case ast.FBDecl(name=name, span=span):
            index.add(Symbol(SymbolKind.BLOCK, key(name)), _head(span, name), Role.DECLARE, decl)
        case ast.TimerDecl(number=n, span=span):
            index.add(Symbol(SymbolKind.TIMER, str(n)), span, Role.DECLARE, decl)
        case ast.CounterDecl(number=n, span=span):
            index.add(Symbol(SymbolKind.COUNTER, str(n)), span, Role.DECLARE, decl)
        case _:
            assert_never(decl)


def _name(statement: ast.Label | ast.Jump | ast.CallFB, file: str, index: ReferenceIndex) -> None:
    match statement:
        case ast.Label(name=name, span=span):
            index.add(Symbol(SymbolKind.LABEL, key(name), file), span, Role.DEFINE, statement)
        case ast.Jump(label=label, span=span):
            index.add(Symbol(SymbolKind.LABEL, key(label), file), _tail(span, label), Role.USE,
                      statement)
        case ast.CallFB(name=name, span=span):
            index.add(Symbol(SymbolKind.BLOCK, key(name)), _tail(span, name), Role.USE, statement)
        case _:
            assert_never(statement)


def operand_symbols(operand: ast.Operand) -> Iterator[Symbol]:
    """The symbols an operand refers to, the most specific first (PARAM's answer in
    ``FY 127`` is one too)."""
    K = ast.OperandKind
    kind = operand.kind
    match kind:
        case K.I | K.I2 | K.Q | K.IB | K.I2B | K.QB:
            yield Symbol(SymbolKind.OPERAND, str(operand).upper())
            yield from map(_slave, operand.slaves())
        case K.F | K.FY | K.PSEG | K.FW:
            yield Symbol(SymbolKind.OPERAND, str(operand).upper())
        case K.T:
            yield Symbol(SymbolKind.TIMER, str(operand.address))
        case K.C:
            yield Symbol(SymbolKind.COUNTER, str(operand.address))
        case K.VAR:
            yield Symbol(SymbolKind.VARIABLE, key(operand.name))
        case K.KP:
            yield _slave(operand.address)
        case K.KT | K.KC | K.KB | K.KW:
            pass
        case _:
            assert_never(kind)
