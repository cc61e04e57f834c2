"""The cross-reference of a program (``asictl xref``, the listing's last section) and the
table of its operands on the Modbus gateway (``asictl xref --modbus``).

The cross-reference answers "who touches this operand?": per operand, in operand order,
the places that read it and those that write it (``file:line`` and the instruction),
and for labels, blocks, variables, timers and counters where they are declared or
defined and used. It is the editors' reference index (``il.references``) laid out as a
table, so ``asictl xref`` and "find references" in an editor always agree.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from asictl.diagnostics import Span
from asictl.il import ast
from asictl.il.language import COUNTER_FLAG_BASE, MAPPED_COUNTERS
from asictl.il.loader import Program
from asictl.il.references import (
    Occurrence,
    ReferenceIndex,
    Role,
    Symbol,
    SymbolKind,
    build_index,
)
from asictl.il.usage import mark as usage_mark
from asictl.platform import gateway as g
from asictl.runtime.firmware import FIRMWARE_BLOCKS
from asictl.runtime.program_map import Variable

#: The rows of one operand, in this order, and how each is headed.
_ROLES = {
    Role.DECLARE: "declared", Role.DEFINE: "defined", Role.READ: "read", Role.WRITE: "write",
    Role.USE: "used",
}
#: The operand marks in cross-reference order.
_AREAS = ("I", "I2", "Q", "F", "IB", "I2B", "QB", "FY", "FW", "PSEG")
_KINDS = (SymbolKind.TIMER, SymbolKind.COUNTER, SymbolKind.VARIABLE, SymbolKind.LABEL,
          SymbolKind.BLOCK)
LEGEND = (
    "marks: the instruction (A AN O ON = S R L T CU CD STP JU JC), G a [GATING] source, "
    ": a label, PARAM its answer in FY 127, BYTE/TIMER/COUNTER/FB a [DECL] line, "
    "file a block's own file"
)


@dataclass(frozen=True)
class Entry:
    """One operand, timer, counter, variable, label or block of the cross-reference."""

    symbol: Symbol
    text: str
    #: what it is beyond its text: a variable's address, a firmware block
    about: str
    rows: tuple[tuple[Role, tuple[Occurrence, ...]], ...]


def operand_parts(name: str) -> tuple[str, int, int]:
    """``"I 4.0"`` -> ``("I", 4, 0)``, ``"FY 10"`` -> ``("FY", 10, -1)``: an operand symbol's
    mark, number and bit."""
    mark, _, place = name.partition(" ")
    number, _, bit = place.partition(".")
    return mark, int(number), int(bit) if bit else -1


def entries(
    program: Program,
    index: ReferenceIndex | None = None,
    *,
    variables: Mapping[str, Variable] | None = None,
) -> list[Entry]:
    """The cross-reference in operand order (slaves, which the operands name, are left
    out). ``variables`` (a compiled program's map) adds each variable's address."""
    index = index if index is not None else build_index(program)
    table = {s: list(o) for s, o in index.by_symbol.items() if s.kind is not SymbolKind.SLAVE}
    order = {file: n for n, file in enumerate(dict.fromkeys(m.file for m in program.modules()))}

    def place(occurrence: Occurrence) -> tuple[int, int, int]:
        span = occurrence.span
        return order.get(span.file, len(order)), span.line, span.column

    result = []
    for symbol in sorted(table, key=_order):
        found = table[symbol]
        rows = tuple(
            (role, tuple(sorted((o for o in found if o.role is role), key=place)))
            for role in _ROLES
            if any(o.role is role for o in found)
        )
        result.append(Entry(symbol, _text(symbol, found), _about(symbol, variables), rows))
    return result


def _order(symbol: Symbol) -> tuple[int, int, int, int, str, str]:
    if symbol.kind is SymbolKind.OPERAND:
        mark, number, bit = operand_parts(symbol.name)
        return 0, _AREAS.index(mark), number, bit, "", ""
    number = int(symbol.name) if symbol.kind in (SymbolKind.TIMER, SymbolKind.COUNTER) else 0
    return 1 + _KINDS.index(symbol.kind), 0, number, 0, symbol.name, symbol.scope


def _text(symbol: Symbol, occurrences: list[Occurrence]) -> str:
    """The symbol as the program writes it (a name as first declared or written)."""
    match symbol.kind:
        case SymbolKind.OPERAND:
            return symbol.name.replace("PSEG", "PSeg")
        case SymbolKind.TIMER:
            return f"T {symbol.name}"
        case SymbolKind.COUNTER:
            return f"C {symbol.name}"
    if symbol.kind is SymbolKind.BLOCK and symbol.name in FIRMWARE_BLOCKS:
        return FIRMWARE_BLOCKS[symbol.name].name
    for occurrence in sorted(occurrences, key=lambda o: o.role is not Role.DECLARE):
        name = _name_of(occurrence.node)
        if name and name.casefold() == symbol.name:
            return name
    return symbol.name


def _name_of(node: ast.BodyNode | None) -> str:
    """The name a variable, label or block has at a place."""
    if isinstance(node, ast.VarDecl | ast.FBDecl | ast.Label):
        return node.name
    if isinstance(node, ast.Jump):
        return node.label
    if isinstance(node, ast.CallFB):
        return node.name
    if isinstance(node, ast.Statement | ast.GatingLine):
        for operand, _ in ast.operands(node):
            if operand.kind is ast.OperandKind.VAR:
                return operand.name
    return ""


def _about(symbol: Symbol, variables: Mapping[str, Variable] | None) -> str:
    if symbol.kind is SymbolKind.BLOCK and symbol.name in FIRMWARE_BLOCKS:
        return "firmware"
    if symbol.kind is SymbolKind.VARIABLE and variables and symbol.name in variables:
        return f"XDATA {variables[symbol.name].address:04X}h"
    return ""


def mark(occurrence: Occurrence) -> str:
    """The instruction at a place, as a cross-reference shows it (``usage.mark``)."""
    node = occurrence.node
    if isinstance(node, ast.Statement | ast.GatingLine | ast.Declaration):
        return usage_mark(node, written=occurrence.role is Role.WRITE)
    return "file" if occurrence.role is Role.DEFINE else ""


def _place(occurrence: Occurrence) -> str:
    span: Span = occurrence.span
    return f"{span.file}:{span.line} {mark(occurrence)}".rstrip()


def xref_text(items: Iterable[Entry], *, prefix: str = "") -> list[str]:
    """The cross-reference as rows, one per operand and access: operand, access, places.

    Every row names its operand and holds all its places, however many, so that a
    ``grep 'Q 2.0'`` finds every place that touches it.
    """
    items = list(items)
    names = [f"{e.text} ({e.about})" if e.about else e.text for e in items]
    width = max([len(n) for n in names] + [len("OPERAND")]) + 2
    rows = [f"{prefix}{'OPERAND':<{width}}{'ACCESS':<10}PLACES"]
    for name, entry in zip(names, items, strict=True):
        rows += [
            f"{prefix}{name:<{width}}{_ROLES[role]:<10}{', '.join(_place(o) for o in places)}"
            for role, places in entry.rows
        ]
    return rows


def xref_json(items: Iterable[Entry]) -> list[dict[str, object]]:
    return [
        {
            "operand": entry.text,
            "kind": entry.symbol.kind.value,
            **({"about": entry.about} if entry.about else {}),
            "references": [
                {
                    "access": _ROLES[role], "mark": mark(o), "file": o.span.file,
                    "line": o.span.line, "column": o.span.column,
                }
                for role, places in entry.rows
                for o in places
            ],
        }
        for entry in items
    ]


# ------------------------------------------------------------------------- Modbus


def modbus_places(mark: str, number: int, bit: int = -1, *, map_counters: bool) -> list[str]:
    """Where the gateway shows an operand (the most direct place first), or nothing.

    ``mark`` is the operand's mark (``I``, ``Q``, ``F``, ``IB``, ``QB``, ``FY``, ``FW``,
    ``C`` ...). The formulas are those of docs/modbus.md: a slave's data bit b is coil /
    discrete input 4n+b and a nibble of data register n/4; flag byte n is holding
    register 400+n and half of register 800+n/2.
    """
    if mark in ("I", "Q") and number > 0:
        register, low = g.data_register(number)
        if mark == "I":
            return [f"discrete input {g.INPUT_BIT_DATA + g.data_bit(number, bit)}",
                    f"input register {g.INPUT_DATA + register} bit {low + bit}"]
        return [f"coil {g.COIL_OUTPUTS + g.data_bit(number, bit)}",
                f"holding register {g.OUTPUT_DATA + register} bit {low + bit}"]
    if mark in ("IB", "QB"):
        base, what = ((g.INPUT_DATA, "input register") if mark == "IB"
                      else (g.OUTPUT_DATA, "holding register"))
        nibbles = ", ".join(
            f"slave {s} bits {g.data_register(s)[1]}-{g.data_register(s)[1] + 3}"
            for s in (number, number + 1) if s > 0
        )
        return [f"{what} {base + g.data_register(number)[0]} ({nibbles})"]
    if mark == "F":
        word, low = g.memory_word(number)
        return [f"holding register {g.MEMORY_BYTES + number} bit {bit}",
                f"holding register {word} bit {low + bit}"]
    if mark == "FY":
        word, low = g.memory_word(number)
        return [f"holding register {g.MEMORY_BYTES + number}",
                f"holding register {word} bits {low}-{low + 7}"]
    if mark == "FW":
        if number % 2 == 0:
            return [f"holding register {g.memory_word(number)[0]}"]
        return [f"holding registers {g.MEMORY_BYTES + number} (high byte) and "
                f"{g.MEMORY_BYTES + number + 1} (low byte)"]
    if mark == "C" and map_counters and 0 <= number < MAPPED_COUNTERS:
        low_byte = COUNTER_FLAG_BASE + 2 * number
        return [f"holding registers {g.MEMORY_BYTES + low_byte} (bits 0-7) and "
                f"{g.MEMORY_BYTES + low_byte + 1} (bits 8-11), through map_counters"]
    return []


_NOT_ON_MODBUS = {
    "I2": "the previous cycle's input image is the program's own",
    "I2B": "the previous cycle's input image is the program's own",
    "T": "timers are the program's own",
    "C": "counters are the program's own (unless map_counters)",
    "PSEG": "PSeg is the program's own",
    "I": "slave 0 exchanges no data", "Q": "slave 0 exchanges no data",
}


def modbus_table(items: Iterable[Entry], *, map_counters: bool) -> list[tuple[str, list[str]]]:
    """Each operand, timer and counter of the program with its Modbus places (or why it
    has none); variables are the program's own and left out."""
    table = []
    for entry in items:
        symbol = entry.symbol
        if symbol.kind is SymbolKind.OPERAND:
            mark, number, bit = operand_parts(symbol.name)
        elif symbol.kind in (SymbolKind.TIMER, SymbolKind.COUNTER):
            mark, number, bit = ("T" if symbol.kind is SymbolKind.TIMER else "C",
                                 int(symbol.name), -1)
        else:
            continue
        places = modbus_places(mark, number, bit, map_counters=map_counters)
        table.append((entry.text, places or [f"not on Modbus: {_NOT_ON_MODBUS[mark]}"]))
    return table


def modbus_text(table: list[tuple[str, list[str]]]) -> list[str]:
    width = max([len(text) for text, _ in table] + [len("OPERAND")]) + 2
    rows = [f"{'OPERAND':<{width}}MODBUS (AS-i/Modbus gateway, PDU addresses)"]
    rows += [f"{text:<{width}}{'; also '.join(places)}" for text, places in table]
    return rows


def modbus_json(table: list[tuple[str, list[str]]]) -> list[dict[str, object]]:
    return [{"operand": text, "modbus": places} for text, places in table]
