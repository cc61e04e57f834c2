"""The board's force list as the host reads it: entries per slave or flag byte, and the
operands they name (``force --list``, the ``forced`` table of ``status``, the monitor).

``forced_values`` names an entry as an operand again: a whole flag byte as ``FY n``, a
slave's four bits as ``I n``/``Q n``, anything less bit by bit (``F 10.0``, ``Q 2.1``).
It stands apart from host/forcing.py, which changes the list through a master, so that
reading a status needs nothing of the master's.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from asictl.board.forcing import BITS, Area
from asictl.observe.symbols import SymbolTable

_LETTER = {Area.INPUTS: "I", Area.OUTPUTS: "Q", Area.FLAGS: "F"}

#: One entry of the board's force list: [area, index, mask, bits]
Entry = tuple[Area, int, int, int]


@dataclass(frozen=True)
class ForcedValue:
    """One forced operand as ``force --list``, ``status`` and the monitor show it."""

    operand: str
    value: int
    #: its name in the program's symbol table, if it has one
    symbol: str | None = None

    def __str__(self) -> str:
        name = f" ({self.symbol})" if self.symbol else ""
        return f"{self.operand}{name} = {self.value}"


def entries_from_json(rows: Iterable[Any]) -> list[Entry]:
    """The board's ``forced`` answer (JSON rows) as entries."""
    return [(Area(str(a)), int(i), int(m), int(b)) for a, i, m, b in rows]


def forced_values(
    entries: Iterable[Entry], symbols: SymbolTable | None = None
) -> list[ForcedValue]:
    """The force list as operands and values, named by ``symbols`` where they have a
    name."""
    values = []
    for area, index, mask, bits in entries:
        letter = _LETTER[area]
        if mask == BITS[area]:
            text = f"FY {index}" if area is Area.FLAGS else f"{letter} {index}"
            values.append((text, bits))
            continue
        for bit in range(8):
            if mask >> bit & 1:
                values.append((f"{letter} {index}.{bit}", bits >> bit & 1))
    return [
        ForcedValue(text, value, symbols.name_of(text) if symbols else None)
        for text, value in values
    ]
