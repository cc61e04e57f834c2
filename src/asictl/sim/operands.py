"""Operands named in scenarios (``"I 4.0"``, ``"QB 16"``, ``"Reading 3"``), read exactly as
the IL reader reads them, so a scenario speaks the program's own language."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from asictl.il import ast
from asictl.il.ast import key
from asictl.il.parser import parse_text

BitNode = ast.ImageBit | ast.TimerRef | ast.CounterRef | ast.VarBit
ByteNode = ast.ImageByte | ast.VarByte


@dataclass(frozen=True)
class Operand:
    node: BitNode | ByteNode

    @property
    def is_bit(self) -> bool:
        return not isinstance(self.node, ast.ImageByte | ast.VarByte)

    @property
    def maximum(self) -> int:
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


def _statement(text: str) -> ast.Statement | None:
    module, diagnostics = parse_text(f"[PROGRAM]\n{text}\n", "<operand>")
    if diagnostics or not module.sections:
        return None
    statements = module.sections[0].statements
    return statements[0] if len(statements) == 1 else None


def parse_operand(text: str, variables: Mapping[str, int] | None = None) -> Operand:
    """Raise ``ValueError`` with a message for the user if ``text`` names no operand.

    ``variables`` are the program's variables (key name -> size in bytes)."""
    if not text.strip() or "\n" in text or ";" in text:
        raise ValueError(f"'{text}' is not an operand")
    statement = _statement(f"A {text}")
    node = statement.operand if isinstance(statement, ast.Logic) else None
    if node is None:
        statement = _statement(f"L {text}")
        loaded = statement.operand if isinstance(statement, ast.Load) else None
        if isinstance(loaded, ast.ImageByte | ast.VarByte):
            node = loaded
    if node is None:
        raise ValueError(
            f"'{text}' is not an operand a scenario can use (bits: I, I2, Q, F, T, C, "
            "variable bits; bytes: IB, I2B, QB, FY, PSeg, variable bytes)"
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
            need(size is not None, f"'{name}' is not a variable declared by the program")
            need(offset < size, f"'{name}' has {size} bytes")
