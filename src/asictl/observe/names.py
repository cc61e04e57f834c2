"""Operands as people read them in reports: bit by bit, with their symbols.

The prover and mutation testing compare and report whole cells (``QB 2`` is one byte
of the output image); a person thinks of ``Q 3.1 (PumpB)``. Every verdict line and note
of ``asictl prove``, ``asictl diff`` and ``asictl mutate`` that shows an operand or a
byte names it here, so that they all say it the same way.
"""

from __future__ import annotations

import re

from asictl.observe.symbols import SymbolTable

_BYTE = re.compile(r"^(QB|FY) (\d+)$")


def named(operand: str, symbols: SymbolTable) -> str:
    """``Q 3.1 (PumpB)``: an operand with its name in the symbol table, if it has one
    (``CV 0 (Parts)`` for the value of a counter named ``Parts``)."""
    label = symbols.label(operand)
    if label == operand:
        return operand
    kind = operand.split(" ", 1)[0] + " "
    return f"{operand} ({label.removeprefix(kind)})"


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


def named_bits(operand: str, first: int, second: int,
               symbols: SymbolTable) -> list[tuple[str, int, int]]:
    """``bits_of`` with each bit named: ``QB 2`` 16 and 48 is ``Q 3.1 (PumpB)`` 0 and 1."""
    return [(named(bit, symbols), a, b) for bit, a, b in bits_of(operand, first, second)]
