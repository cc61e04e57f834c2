"""Watch tables: the values of chosen operands on a master, read again and again, for
``asictl watch`` and the monitor's watch view (docs/commissioning.md, "Watch tables").

A watch list is operands or names of the board's symbol table (host/symbols.py), given
on the command line or in a ``FILE.watch.toml``::

    watch = ["Start", "F 10.0", "FY 11", "Q 2", "CV 0"]

Values come from the master's status (``MasterStatus``): flags, the slaves' input and
output data, and on an emulated board the program's timers and counters. What the host
cannot see (the previous-cycle image I2, PSeg, the program's variables) is refused when
the list is read, not while it is watched.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from asictl.codes import ScenarioCode
from asictl.diagnostics import DiagnosticError
from asictl.errors import ExitCode, UserError
from asictl.host.status import VISIBLE, MasterStatus, operand_value
from asictl.host.symbols import Names
from asictl.observe.operands import Operand
from asictl.readers.tomlfile import read_toml
from asictl.source import SourceText

#: What a watch list may hold, as messages say it.
WATCHABLE = ("inputs (I, IB), outputs (Q, QB), flags (F, FY), and on an emulated board "
             "timers and counters (T, C, TV, CV)")


@dataclass(frozen=True)
class Watched:
    """One operand of a watch list: as it prints, and its name where the board has one."""

    operand: Operand
    symbol: str | None = None

    @property
    def text(self) -> str:
        return str(self.operand)

    @property
    def label(self) -> str:
        return f"{self.text} ({self.symbol})" if self.symbol else self.text


def read_table(source: SourceText) -> list[str]:
    """The operands of a ``FILE.watch.toml`` (``watch = [...]``); ``DiagnosticError`` at
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
    return list(items)


def watch_list(names: Names, items: Sequence[str]) -> list[Watched]:
    """The operands ``items`` name (each once, in order); ``UserError`` exit 2 for one the
    host cannot see."""
    watched: list[Watched] = []
    for text in items:
        operand = names.operand(text)
        if operand.node.kind not in VISIBLE:
            raise UserError(f"'{text}' cannot be watched from the host: a watch shows "
                            f"{WATCHABLE}", ExitCode.USAGE)
        entry = Watched(operand, names.table.label(str(operand)) or None)
        if entry.symbol == entry.text:
            entry = Watched(operand)
        if all(w.text != entry.text for w in watched):
            watched.append(entry)
    if not watched:
        raise UserError("nothing to watch: name operands or give --table FILE.watch.toml",
                        ExitCode.USAGE)
    return watched


def values(status: MasterStatus, watched: Sequence[Watched]) -> list[int]:
    return [operand_value(status, w.operand) for w in watched]
