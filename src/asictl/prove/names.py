"""Operands as people read them in the prover's notes: bit by bit, with their symbols.

The prover compares and reports whole cells (``QB 2`` is one byte of the output image);
a person thinks of ``Q 3.1 (PumpB)``. Nothing here needs z3.
"""

from __future__ import annotations

import re

from asictl.observe.symbols import SymbolTable

_BYTE = re.compile(r"^(QB|FY) (\d+)$")


def named(operand: str, symbols: SymbolTable) -> str:
    """``Q 3.1 (PumpB)``: an operand with its name in the symbol table, if it has one."""
    label = symbols.label(operand)
    return operand if label == operand else f"{operand} ({label})"


def bits_of(operand: str, first: int, second: int) -> list[tuple[str, int, int]]:
    """A difference of a byte as the bits that differ (``QB 2`` 16 and 48: ``Q 3.1`` 0
    and 1; an output byte holds slave n in bits 0-3 and slave n+1 in bits 4-7); any
    other operand as it is."""
    match = _BYTE.match(operand)
    if match is None:
        return [(operand, first, second)]
    kind, number = match[1], int(match[2])
    found = []
    for bit in range(8):
        a, b = first >> bit & 1, second >> bit & 1
        if a != b:
            text = (f"Q {number + bit // 4}.{bit % 4}" if kind == "QB"
                    else f"F {number}.{bit}")
            found.append((text, a, b))
    return found
