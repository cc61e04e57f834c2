"""Operands named in scenarios (``"I 4.0"``, ``"QB 16"``, ``"Reading 3"``), read exactly as
the IL reader reads them, so a scenario speaks the program's own language.

Two operands are the simulator's own, for what people check when they debug: ``CV n``, a
counter's value (0..4095), and ``TV n``, a timer's remaining time in milliseconds. A
symbol table (``asictl.observe.symbols``) may name any of them.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import assert_never

from asictl.il import ast
from asictl.il.ast import key
from asictl.il.language import TC_MAX_VALUE
from asictl.il.parser import parse_text
from asictl.observe.symbols import SymbolTable
from asictl.platform.master import TICK_MS

_VALUE = re.compile(r"^\s*(CV|TV)\s*(\d{1,6})\s*$", re.IGNORECASE)
#: The largest remaining time a timer can hold, in milliseconds.
TIMER_MAX_MS = TC_MAX_VALUE * TICK_MS
K = ast.OperandKind


@dataclass(frozen=True)
class Operand:
    """An operand as a scenario, a trace or the debugger names it: an IL operand, a bit or
    a byte, or one of the simulator's own two, ``CV n`` and ``TV n``, which are counter n
    and timer n as words (``L C n``, ``L T n``): the count, and the remaining time, here
    in milliseconds."""

    node: ast.Operand

    @classmethod
    def value_of(cls, kind: ast.OperandKind, number: int) -> Operand:
        """``CV n`` (kind C) or ``TV n`` (kind T)."""
        return cls(ast.Operand(kind, number, -1, ast.Width.WORD))

    @property
    def is_bit(self) -> bool:
        return self.node.width is ast.Width.BIT

    @property
    def width(self) -> int:
        """Bits a trace needs for it: 1, 8, 12 (a count) or 16 (milliseconds)."""
        node = self.node
        if node.width is ast.Width.WORD:
            return 12 if node.kind is K.C else 16
        return int(node.width)

    @property
    def maximum(self) -> int:
        node = self.node
        if node.width is ast.Width.WORD:
            return TC_MAX_VALUE if node.kind is K.C else TIMER_MAX_MS
        return 1 if node.width is ast.Width.BIT else 255

    @property
    def settable(self) -> bool:
        """A scenario writes inputs (as slaves deliver them) and flags (as a host does)."""
        return self.node.kind in (K.I, K.F, K.IB, K.FY)

    def __str__(self) -> str:
        node = self.node
        if node.width is ast.Width.WORD and node.kind in (K.T, K.C):
            return f"{node.kind.value}V {node.address}"
        return str(node)


@functools.lru_cache(maxsize=4096)
def _statement(text: str) -> ast.Statement | None:
    """The one statement ``text`` is (scenarios name the same operands again and again)."""
    module, diagnostics = parse_text(f"[PROGRAM]\n{text}\n", "<operand>")
    if diagnostics or not module.sections:
        return None
    section = module.sections[0]
    if not isinstance(section, ast.ProgramSection) or len(section.statements) != 1:
        return None
    return section.statements[0]


def parse_operand(
    text: str, variables: Mapping[str, int] | None = None, symbols: SymbolTable | None = None
) -> Operand:
    """Raise ``ValueError`` with a message for the user if ``text`` names no operand.

    ``variables`` are the program's variables (key name -> size in bytes); ``symbols``
    the names of its symbol table."""
    if symbols:
        text = symbols.resolve(text)
    if not text.strip() or "\n" in text or ";" in text:
        raise ValueError(f"'{text}' is not an operand")
    value = _VALUE.match(text)
    if value:
        number = int(value[2])
        if number > 1023:
            raise ValueError(f"'{text}': number 0..1023")
        return Operand.value_of(K.C if value[1].upper() == "CV" else K.T, number)
    statement = _statement(f"A {text}")
    node = statement.operand if isinstance(statement, ast.Logic) else None
    if node is None:
        statement = _statement(f"L {text}")
        loaded = statement.operand if isinstance(statement, ast.Load) else None
        if loaded is not None and loaded.width is ast.Width.BYTE:
            node = loaded
    if node is None:
        raise ValueError(
            f"'{text}' is not an operand a scenario can use (bits: I, I2, Q, F, T, C, "
            "variable bits; bytes: IB, I2B, QB, FY, PSeg, variable bytes; values: CV n, "
            "TV n" + ("; or a symbol" if symbols else "") + ")"
        )
    _check_range(node, text, variables or {})
    return Operand(node)


def _check_range(node: ast.Operand, text: str, variables: Mapping[str, int]) -> None:
    def need(ok: bool, what: str) -> None:
        if not ok:
            raise ValueError(f"'{text}': {what}")

    a, b = node.address, node.bit
    match node.kind:
        case K.F:
            need(a <= 127 and b <= 7, "flag byte 0..127, bit 0..7")
        case K.I | K.I2 | K.Q:
            need(a <= 31 and b <= 3, "slave 0..31, data bit 0..3")
        case K.T | K.C:
            need(a <= 1023, "number 0..1023")
        case K.FY:
            need(a <= 127, "flag byte 0..127")
        case K.PSEG:
            need(a <= 15, "PSeg byte 0..15")
        case K.IB | K.I2B | K.QB:
            need(a <= 30 and a % 2 == 0, "an even slave address 0..30")
        case K.VAR:
            size = variables.get(key(node.name))
            if size is None:
                raise ValueError(
                    f"'{text}': '{node.name}' is not a variable declared by the program")
            need(a < size, f"'{node.name}' has {size} bytes")
        case K.FW | K.KT | K.KC | K.KB | K.KW | K.KP:
            raise AssertionError(f"{node} is read neither as a bit nor as a byte")
        case _:
            assert_never(node.kind)
