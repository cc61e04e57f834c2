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

from asictl.il import ast
from asictl.il.ast import key
from asictl.il.language import TC_MAX_VALUE
from asictl.il.parser import parse_text
from asictl.observe.symbols import SymbolTable
from asictl.platform.master import TICK_MS


@dataclass(frozen=True)
class CounterValue:
    """``CV n``: counter n's value, 0..4095."""

    number: int

    def __str__(self) -> str:
        return f"CV {self.number}"


@dataclass(frozen=True)
class TimerValue:
    """``TV n``: timer n's remaining time in milliseconds (10 ms steps)."""

    number: int

    def __str__(self) -> str:
        return f"TV {self.number}"


BitNode = ast.ImageBit | ast.TimerRef | ast.CounterRef | ast.VarBit
ByteNode = ast.ImageByte | ast.VarByte
ValueNode = CounterValue | TimerValue
_VALUE = re.compile(r"^\s*(CV|TV)\s*(\d{1,6})\s*$", re.IGNORECASE)
#: The largest remaining time a timer can hold, in milliseconds.
TIMER_MAX_MS = TC_MAX_VALUE * TICK_MS


@dataclass(frozen=True)
class Operand:
    node: BitNode | ByteNode | ValueNode

    @property
    def is_bit(self) -> bool:
        return not isinstance(self.node, ast.ImageByte | ast.VarByte | CounterValue | TimerValue)

    @property
    def width(self) -> int:
        """Bits a trace needs for it: 1, 8, 12 (a count) or 16 (milliseconds)."""
        match self.node:
            case CounterValue():
                return 12
            case TimerValue():
                return 16
            case ast.ImageByte() | ast.VarByte():
                return 8
        return 1

    @property
    def maximum(self) -> int:
        match self.node:
            case CounterValue():
                return TC_MAX_VALUE
            case TimerValue():
                return TIMER_MAX_MS
        return 1 if self.is_bit else 255

    @property
    def settable(self) -> bool:
        """A scenario writes inputs (as slaves deliver them) and flags (as a host does)."""
        match self.node:
            case ast.ImageBit(area=area):
                return area in (ast.BitArea.I, ast.BitArea.F)
            case ast.ImageByte(area=area):
                return area in (ast.ByteArea.IB, ast.ByteArea.FY)
        return False

    def __str__(self) -> str:
        return str(self.node)


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
        kind = CounterValue if value[1].upper() == "CV" else TimerValue
        return Operand(kind(number))
    statement = _statement(f"A {text}")
    node: BitNode | ByteNode | None = (
        statement.operand if isinstance(statement, ast.Logic) else None
    )
    if node is None:
        statement = _statement(f"L {text}")
        loaded = statement.operand if isinstance(statement, ast.Load) else None
        if isinstance(loaded, ast.ImageByte | ast.VarByte):
            node = loaded
    if node is None:
        raise ValueError(
            f"'{text}' is not an operand a scenario can use (bits: I, I2, Q, F, T, C, "
            "variable bits; bytes: IB, I2B, QB, FY, PSeg, variable bytes; values: CV n, "
            "TV n" + ("; or a symbol" if symbols else "") + ")"
        )
    _check_range(node, text, variables or {})
    return Operand(node)


def _check_range(node: BitNode | ByteNode, text: str, variables: Mapping[str, int]) -> None:
    def need(ok: bool, what: str) -> None:
        if not ok:
            raise ValueError(f"'{text}': {what}")

    match node:
        case ast.ImageBit(area=ast.BitArea.F, address=a, bit=b):
            need(a <= 127 and b <= 7, "flag byte 0..127, bit 0..7")
        case ast.ImageBit(address=a, bit=b):
            need(a <= 31 and b <= 3, "slave 0..31, data bit 0..3")
        case ast.TimerRef(number=n) | ast.CounterRef(number=n):
            need(n <= 1023, "number 0..1023")
        case ast.ImageByte(area=ast.ByteArea.FY, number=n):
            need(n <= 127, "flag byte 0..127")
        case ast.ImageByte(area=ast.ByteArea.PSEG, number=n):
            need(n <= 15, "PSeg byte 0..15")
        case ast.ImageByte(number=n):
            need(n <= 30 and n % 2 == 0, "an even slave address 0..30")
        case ast.VarBit(name=name, offset=offset) | ast.VarByte(name=name, offset=offset):
            size = variables.get(key(name))
            if size is None:
                raise ValueError(f"'{text}': '{name}' is not a variable declared by the program")
            need(offset < size, f"'{name}' has {size} bytes")
