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

import tomllib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from asictl.errors import ExitCode, UserError
from asictl.host.status import MasterStatus, SlaveData
from asictl.host.symbols import Names
from asictl.il import ast
from asictl.observe.operands import Operand
from asictl.source import read_source

K = ast.OperandKind
#: What a watch list may hold, as messages say it.
WATCHABLE = ("inputs (I, IB), outputs (Q, QB), flags (F, FY), and on an emulated board "
             "timers and counters (T, C, TV, CV)")
_VISIBLE = (K.I, K.IB, K.Q, K.QB, K.F, K.FY, K.T, K.C)


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


def read_table(path: str | Path) -> list[str]:
    """The operands of a ``FILE.watch.toml`` (``watch = [...]``); ``UserError`` exit 2."""
    source = read_source(path)
    try:
        data = tomllib.loads(source.text)
    except tomllib.TOMLDecodeError as exc:
        raise UserError(f"{source.name}: not a watch table: {exc}", ExitCode.USAGE) from None
    items = data.get("watch")
    if not isinstance(items, list) or not all(isinstance(i, str) for i in items) or (
            set(data) - {"watch"}):
        raise UserError(
            f"{source.name}: a watch table is one list of operands or names: "
            'watch = ["F 10.0", "Motor"]', ExitCode.USAGE)
    return list(items)


def watch_list(names: Names, items: Sequence[str]) -> list[Watched]:
    """The operands ``items`` name (each once, in order); ``UserError`` exit 2 for one the
    host cannot see."""
    watched: list[Watched] = []
    for text in items:
        operand = names.operand(text)
        if operand.node.kind not in _VISIBLE:
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


def value(status: MasterStatus, operand: Operand) -> int:
    """The operand's value in ``status``; ``UserError`` (exit 1) for a timer or counter on
    a master that does not show them."""
    node = operand.node
    a, bit = node.address, node.bit
    match node.kind:
        case K.F:
            return status.flags[a] >> bit & 1
        case K.FY:
            return status.flags[a]
        case K.I | K.Q:
            data = _data(status, a, node.kind is K.I)
            return data >> bit & 1 if bit >= 0 else data
        case K.IB | K.QB:
            inputs = node.kind is K.IB
            return _data(status, a, inputs) | _data(status, a + 1, inputs) << 4
        case K.T | K.C:
            return _timer_or_counter(status, operand)
    raise AssertionError(f"{operand} is not watched")  # watch_list refuses the rest


def _data(status: MasterStatus, slave: int, inputs: bool) -> int:
    row: SlaveData | None = status.slaves.get(str(slave))
    if row is None:
        return 0
    return row.inputs if inputs else row.outputs


def _timer_or_counter(status: MasterStatus, operand: Operand) -> int:
    node = operand.node
    if node.kind is K.T:
        if status.timers is None:
            raise UserError(f"'{operand}': only an emulated board shows the program's timers",
                            ExitCode.FAILED)
        timer = next((t for t in status.timers if t.number == node.address), None)
        remaining = timer.remaining_ms if timer else 0
        return int(remaining != 0) if operand.is_bit else remaining
    if status.counters is None:
        raise UserError(f"'{operand}': only an emulated board shows the program's counters",
                        ExitCode.FAILED)
    counter = next((c for c in status.counters if c.number == node.address), None)
    count = counter.value if counter else 0
    return int(count != 0) if operand.is_bit else count


def values(status: MasterStatus, watched: Sequence[Watched]) -> list[int]:
    return [value(status, w.operand) for w in watched]
