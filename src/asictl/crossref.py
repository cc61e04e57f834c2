"""The cross-reference of a program (``asictl xref``, the listing's last section) and the
table of its operands on the Modbus gateway (``asictl xref --modbus``).

The cross-reference answers "who touches this operand?": per operand, in operand order,
the places that read it and those that write it (``file:line`` and the instruction),
and for labels and blocks where they are defined and used. It is made from the
reference index (``il.xref``) the analyses use, so both see the same program.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from asictl.il.language import COUNTER_FLAG_BASE, MAPPED_COUNTERS
from asictl.il.xref import (
    Access,
    Reference,
    ReferenceIndex,
    Symbol,
    SymbolKind,
    is_firmware_block,
    slaves_of,
)
from asictl.platform import gateway as g
from asictl.runtime.program_map import Variable

#: The order of the access rows of one operand.
_ACCESS_ORDER = (Access.DEFINE, Access.READ, Access.WRITE, Access.USE)
LEGEND = (
    "marks: the instruction (A AN O ON = S R L T CU CD STP JU JC), G a [GATING] source, "
    ": a label, PARAM its answer in F 127, BYTE/TIMER/COUNTER/FB a [DECL] line"
)


@dataclass(frozen=True)
class Entry:
    """One operand, label or block of the cross-reference."""

    symbol: Symbol
    text: str
    #: what the operand is beyond its text: a variable's address, a firmware block
    about: str
    rows: tuple[tuple[Access, tuple[Reference, ...]], ...]


def entries(
    index: ReferenceIndex, *, variables: Mapping[str, Variable] | None = None
) -> list[Entry]:
    """The cross-reference in operand order. ``variables`` (a compiled program's map)
    adds each variable's address."""
    order = {file: n for n, file in enumerate(index.files)}

    def place(reference: Reference) -> tuple[int, int, int]:
        span = reference.span
        return order.get(span.file, len(order)), span.line, span.column

    result = []
    for symbol, references in index.by_symbol().items():
        rows = tuple(
            (access, tuple(sorted((r for r in references if r.access is access), key=place)))
            for access in _ACCESS_ORDER
            if any(r.access is access for r in references)
        )
        result.append(Entry(symbol, index.text(symbol), _about(symbol, variables), rows))
    return result


def _about(symbol: Symbol, variables: Mapping[str, Variable] | None) -> str:
    if is_firmware_block(symbol):
        return "firmware"
    if symbol.kind is SymbolKind.VARIABLE and symbol.number < 0 and variables:
        variable = variables.get(symbol.name)
        if variable is not None:
            return f"XDATA {variable.address:04X}h"
    return ""


def _place(reference: Reference) -> str:
    return f"{reference.span.file}:{reference.span.line} {reference.mark}"


def xref_text(items: Iterable[Entry], *, prefix: str = "") -> list[str]:
    """The cross-reference as rows, one per operand and access: operand, access, places.

    Every row names its operand and holds all its places, however many, so that a
    ``grep 'Q 2.0'`` finds every place that touches it.
    """
    items = list(items)
    names = [f"{e.text} ({e.about})" if e.about else e.text for e in items]
    width = max([len(n) for n in names] + [len("OPERAND")]) + 2
    rows = [f"{prefix}{'OPERAND':<{width}}{'ACCESS':<9}PLACES"]
    for name, entry in zip(names, items, strict=True):
        rows += [
            f"{prefix}{name:<{width}}{access.value:<9}{', '.join(_place(r) for r in references)}"
            for access, references in entry.rows
        ]
    return rows


def xref_json(items: Iterable[Entry]) -> str:
    return json.dumps(
        [
            {
                "operand": entry.text,
                "kind": entry.symbol.kind.name.lower(),
                **({"about": entry.about} if entry.about else {}),
                "references": [
                    {
                        "access": access.value, "mark": r.mark, "file": r.span.file,
                        "line": r.span.line, "column": r.span.column,
                    }
                    for access, references in entry.rows
                    for r in references
                ],
            }
            for entry in items
        ],
        indent=2,
    ) + "\n"


# ------------------------------------------------------------------------- Modbus


def modbus_places(symbol: Symbol, *, map_counters: bool) -> list[str]:
    """Where the gateway shows an operand (the first is the most direct), or nothing.

    The formulas are those of docs/modbus.md: a slave's data bit b is coil / discrete
    input 4n+b and a nibble of data register n/4; flag byte n is holding register
    400+n and half of register 800+n/2.
    """
    kind, n, bit = symbol.kind, symbol.number, symbol.bit
    if kind in (SymbolKind.INPUT, SymbolKind.OUTPUT) and n > 0:
        register, low = g.data_register(n)
        if kind is SymbolKind.INPUT:
            return [f"discrete input {g.INPUT_BIT_DATA + g.data_bit(n, bit)}",
                    f"input register {g.INPUT_DATA + register} bit {low + bit}"]
        return [f"coil {g.COIL_OUTPUTS + g.data_bit(n, bit)}",
                f"holding register {g.OUTPUT_DATA + register} bit {low + bit}"]
    if kind in (SymbolKind.INPUT_BYTE, SymbolKind.OUTPUT_BYTE):
        base = g.INPUT_DATA if kind is SymbolKind.INPUT_BYTE else g.OUTPUT_DATA
        what = "input register" if kind is SymbolKind.INPUT_BYTE else "holding register"
        register, _ = g.data_register(n)
        nibbles = ", ".join(
            f"slave {s} bits {g.data_register(s)[1]}-{g.data_register(s)[1] + 3}"
            for s in slaves_of(symbol) if s > 0
        )
        return [f"{what} {base + register} ({nibbles})"] if nibbles else []
    if kind is SymbolKind.FLAG:
        word, low = g.memory_word(n)
        return [f"holding register {g.MEMORY_BYTES + n} bit {bit}",
                f"holding register {word} bit {low + bit}"]
    if kind is SymbolKind.FLAG_BYTE:
        word, low = g.memory_word(n)
        return [f"holding register {g.MEMORY_BYTES + n}",
                f"holding register {word} bits {low}-{low + 7}"]
    if kind is SymbolKind.FLAG_WORD:
        if n % 2 == 0:
            return [f"holding register {g.memory_word(n)[0]}"]
        return [f"holding registers {g.MEMORY_BYTES + n} (high byte) and "
                f"{g.MEMORY_BYTES + n + 1} (low byte)"]
    if kind is SymbolKind.COUNTER and map_counters and 0 <= n < MAPPED_COUNTERS:
        low_byte = COUNTER_FLAG_BASE + 2 * n
        return [f"holding registers {g.MEMORY_BYTES + low_byte} (bits 0-7) and "
                f"{g.MEMORY_BYTES + low_byte + 1} (bits 8-11), through map_counters"]
    return []


_NOT_ON_MODBUS = {
    SymbolKind.OLD_INPUT: "the previous cycle's input image is the program's own",
    SymbolKind.OLD_INPUT_BYTE: "the previous cycle's input image is the program's own",
    SymbolKind.TIMER: "timers are the program's own",
    SymbolKind.COUNTER: "counters are the program's own (unless map_counters)",
    SymbolKind.PSEG: "PSeg is the program's own",
    SymbolKind.VARIABLE: "variables are the program's own",
}


def modbus_table(index: ReferenceIndex, *, map_counters: bool) -> list[tuple[str, list[str]]]:
    """Each operand of the program with its Modbus places (empty: none, and why)."""
    table = []
    for symbol in sorted({r.symbol for r in index.references}):
        if symbol.kind in (SymbolKind.LABEL, SymbolKind.BLOCK) or (
            symbol.kind is SymbolKind.VARIABLE and symbol.number < 0
        ):
            continue
        places = modbus_places(symbol, map_counters=map_counters)
        if not places:
            reason = _NOT_ON_MODBUS.get(symbol.kind, "slave 0 exchanges no data")
            places = [f"not on Modbus: {reason}"]
        table.append((index.text(symbol), places))
    return table


def modbus_text(table: list[tuple[str, list[str]]]) -> list[str]:
    width = max([len(text) for text, _ in table] + [len("OPERAND")]) + 2
    rows = [f"{'OPERAND':<{width}}MODBUS (AS-i/Modbus gateway, PDU addresses)"]
    rows += [f"{text:<{width}}{'; also '.join(places)}" for text, places in table]
    return rows


def modbus_json(table: list[tuple[str, list[str]]]) -> str:
    return json.dumps(
        [{"operand": text, "modbus": places} for text, places in table], indent=2
    ) + "\n"
