"""Watch tables: the values of chosen operands on a master, read again and again, for
``asictl watch`` and the monitor's watch view (docs/commissioning.md, "Watch tables").

A watch list is operands or names of the board's symbol table (host/symbols.py), or
conditions over them (docs/conditions.md: the language of plant rules, properties and
breakpoints), given on the command line or in a ``FILE.watch.toml``::

    watch = ["Start", "F 10.0", "FY 11", "Q 2", "CV 0", "Forward and not Stop"]

A condition is watched as a bit: 1 while it holds, 0 while it does not.

Values come from the master's status (``MasterStatus``): flags, the slaves' input and
output data, and on an emulated board the program's timers and counters. What the host
cannot see (the previous-cycle image I2, PSeg, the program's variables) is refused when
the list is read, not while it is watched.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity
from asictl.errors import ExitCode, UserError
from asictl.host.status import VISIBLE, MasterStatus, operand_value
from asictl.host.symbols import Names
from asictl.observe.condition import Condition, ConditionError, parse_condition
from asictl.observe.operands import Operand
from asictl.readers.tomlfile import Document, read_toml
from asictl.source import SourceText

#: What a watch list may hold, as messages say it.
WATCHABLE = ("inputs (I, IB), outputs (Q, QB), flags (F, FY), and on an emulated board "
             "timers and counters (T, C, TV, CV)")


#: What tells a condition from an operand or a name: an operator, a comparison, brackets.
_CONDITION = re.compile(r"[()=<>!]|\b(and|or|xor|not|true|false)\b", re.IGNORECASE)


@dataclass(frozen=True)
class Watched:
    """One entry of a watch list: an operand (as it prints, and its name where the board
    has one), or a condition, which reads as a bit (1 while it holds)."""

    operand: Operand | None
    symbol: str | None = None
    condition: Condition | None = None

    @property
    def text(self) -> str:
        return str(self.operand) if self.operand is not None else str(self.condition)

    @property
    def label(self) -> str:
        return f"{self.text} ({self.symbol})" if self.symbol else self.text

    @property
    def width(self) -> int:
        """How many bits the value has (a condition: one)."""
        return self.operand.width if self.operand is not None else 1

    def value(self, status: MasterStatus) -> int:
        if self.condition is not None:
            return int(self.condition(lambda operand: operand_value(status, operand)))
        assert self.operand is not None
        return operand_value(status, self.operand)


@dataclass(frozen=True)
class WatchTable:
    """A ``FILE.watch.toml``'s entries, and its document to place a mistake found later
    (a condition naming what the board's symbol table lacks) at its item."""

    items: list[str]
    document: Document


def read_table(source: SourceText) -> WatchTable:
    """The entries of a ``FILE.watch.toml`` (``watch = [...]``); ``DiagnosticError`` at
    the place that is wrong."""

    document = read_toml(source.name, source.text)
    data = document.data
    unknown = document.unknown_keys((), data, ("watch",))
    if unknown:
        raise DiagnosticError(unknown)
    items = data.get("watch")
    if not isinstance(items, list) or not all(isinstance(i, str) for i in items):
        wrong = next((i for i, item in enumerate(items) if not isinstance(item, str)), None) \
            if isinstance(items, list) else None
        raise DiagnosticError([document.error(
            ScenarioCode.INVALID, 'a watch table is one list of operands or names: '
            'watch = ["F 10.0", "Motor"]', ("watch",) if wrong is None else ("watch", wrong),
            at_value=True)])
    return WatchTable(list(items), document)


def watch_list(names: Names, items: Sequence[str], table: WatchTable | None = None
               ) -> list[Watched]:
    """The operands and conditions ``items`` name (each once, in order); ``UserError``
    exit 2 for one the host cannot see. A condition that cannot be read is a
    ``DiagnosticError`` (E410) inside its string when it came from ``table`` (whose
    items come first), else a ``UserError`` showing it with a caret."""
    watched: list[Watched] = []
    for index, text in enumerate(items):
        try:
            entry = _entry(names, text)
        except ConditionError as exc:
            if table is not None and index < len(table.items):
                place = table.document.inside(("watch", index), exc.offset, exc.length)
                raise DiagnosticError([Diagnostic(Severity.ERROR, ScenarioCode.CONDITION,
                                                  exc.message, place)]) from None
            shown = "\n".join(exc.caret(text))
            raise UserError(f"watch condition: {exc.message}\n{shown}",
                            ExitCode.USAGE) from None
        if all(w.text != entry.text for w in watched):
            watched.append(entry)
    if not watched:
        raise UserError("nothing to watch: name operands or give --table FILE.watch.toml",
                        ExitCode.USAGE)
    return watched


def _entry(names: Names, text: str) -> Watched:
    try:
        operand = names.operand(text)
    except UserError:
        if not _CONDITION.search(text):
            raise
        condition = parse_condition(text, symbols=names.table)
        for read in condition.operands:
            _visible(read, text)
        return Watched(None, condition=condition)
    _visible(operand, text)
    entry = Watched(operand, names.table.label(str(operand)) or None)
    return Watched(operand) if entry.symbol == entry.text else entry


def _visible(operand: Operand, text: str) -> None:
    if operand.node.kind not in VISIBLE:
        raise UserError(f"'{text}' cannot be watched from the host: a watch shows "
                        f"{WATCHABLE}", ExitCode.USAGE)


def values(status: MasterStatus, watched: Sequence[Watched]) -> list[int]:
    return [w.value(status) for w in watched]
