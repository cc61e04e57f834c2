"""IL coverage of a running program: lines, branches and conditions (docs/testing.md).

What is counted comes from the program's source: every statement line that has code
(not labels alone, not ``***``, not comments or declarations), every conditional jump
(``JC``, ``JC FB``) and ``BEC`` with how often it was taken and not taken, and every
bit operand of ``A``/``AN``/``O``/``ON`` and of a [GATING] line with how often it was
read as 0 and as 1. Function blocks' files count as files of their own.

How it is counted without slowing the simulation much: a program cycle is a function
of the machine's state at its start (internal RAM, SFRs, the communication memory, the
program's data, the input images) as long as it calls no firmware block; the remaining
time of a running timer, which the 10 ms clock counts down, is left out unless the
program reads it (``L T n``, or ASM: the image says which): the program sees only the
timer's status. The first
cycle from each state runs in the emulator's interpreter with a function called after
every instruction; that sees each IL line's first instruction run (its first address in
the line map), the single-bit register at each branch (the first instruction of a JC or
BEC line is the 8051 jump that tests it and leaves it as it is) and the operands' values
at each condition (a reading line writes none of them), and makes the cycle's record.
A later cycle from a state already seen runs at full speed and adds that record once
more. A cycle that calls a firmware block (whose answers come from outside the
machine) is always watched. Either way every cycle really
runs, so coverage never changes a result. The master skips cycles that would repeat
the last one exactly and tells how many it skipped (``Pc2Board.repeated``): each counts
as the last one run, so each hit count is the number of program cycles that ran the line
without the emulator running each of them.
"""

from __future__ import annotations

import os
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import Any, TypeVar

from asictl.il import ast
from asictl.il.loader import Program
from asictl.mcs51.emulator import Emulator
from asictl.mcs51.isa import SFRS
from asictl.observe.operands import Operand
from asictl.observe.view import ProgramView
from asictl.runtime import layout
from asictl.runtime.line_map import LineMap, SourceLine
from asictl.runtime.runner import ProgramRunner, Trace

_PSW = SFRS["PSW"]
_CARRY = 0x80
#: The most cycle records kept for reuse (a few hundred bytes each): beyond them a
#: program that keeps reaching new states has its new cycles watched and added up.
MAX_RECORDS = 65_536

#: (file, line): a statement line; the file as the program was loaded (absolute)
LineKey = tuple[str, int]
#: (file, line, column, operand as written)
ConditionKey = tuple[str, int, int, str]
_Key = TypeVar("_Key", LineKey, ConditionKey)


@dataclass
class Coverage:
    """What the scenarios of a run reached; plain data (it crosses worker processes) that
    adds up over scenarios with ``merge``."""

    #: every statement line with code -> how many times it ran
    lines: dict[LineKey, int] = field(default_factory=dict)
    #: every JC, JC FB and BEC line -> [times taken, times not taken]
    branches: dict[LineKey, list[int]] = field(default_factory=dict)
    #: every bit operand of a condition -> [times read as 0, times read as 1]
    conditions: dict[ConditionKey, list[int]] = field(default_factory=dict)

    def merge(self, other: Coverage) -> None:
        for key, hits in other.lines.items():
            self.lines[key] = self.lines.get(key, 0) + hits
        _add_pairs(self.branches, other.branches)
        _add_pairs(self.conditions, other.conditions)

    def totals(self) -> dict[str, tuple[int, int]]:
        """Kind -> (covered, counted): lines; branches and conditions by outcome (two
        each: taken and not taken, read as 0 and as 1)."""
        return {
            "lines": (sum(1 for h in self.lines.values() if h), len(self.lines)),
            "branches": _outcomes(self.branches.values()),
            "conditions": _outcomes(self.conditions.values()),
        }

    def to_data(self) -> dict[str, list[list[object]]]:
        """As JSON-able lists (what the pytest plugin's workers send their controller)."""
        return {
            "lines": [[*key, hits] for key, hits in self.lines.items()],
            "branches": [[*key, *counts] for key, counts in self.branches.items()],
            "conditions": [[*key, *counts] for key, counts in self.conditions.items()],
        }

    @classmethod
    def from_data(cls, data: dict[str, list[list[Any]]]) -> Coverage:
        return cls(
            {(str(f), int(n)): int(h) for f, n, h in data["lines"]},
            {(str(f), int(n)): [int(t), int(u)] for f, n, t, u in data["branches"]},
            {(str(f), int(n), int(c), str(o)): [int(z), int(w)]
             for f, n, c, o, z, w in data["conditions"]},
        )

    def reached(self) -> set[LineKey]:
        """The statement lines that ran."""
        return {key for key, hits in self.lines.items() if hits}

    def files(self) -> list[str]:
        return sorted({file for file, _ in self.lines})

    def files_read(self) -> list[Path]:
        """The program files counted (no report may replace one of them)."""
        return [Path(file) for file in self.files()]


def _add_pairs(mine: dict[_Key, list[int]], theirs: dict[_Key, list[int]]) -> None:
    for key, (first, second) in theirs.items():
        pair = mine.setdefault(key, [0, 0])
        pair[0] += first
        pair[1] += second


def _outcomes(pairs: Iterable[list[int]]) -> tuple[int, int]:
    values = list(pairs)
    return sum(bool(a) + bool(b) for a, b in values), 2 * len(values)


@dataclass(frozen=True)
class _Point:
    """What happens when the PC reaches a line's first address."""

    line: int
    #: the branch's index, or -1
    branch: int
    #: (condition index, the operand read)
    conditions: tuple[tuple[int, Operand], ...]


@dataclass
class _Record:
    """One watched cycle: indices of lines run, (branch, taken), (condition, value)."""

    lines: Counter[int] = field(default_factory=Counter)
    branches: Counter[tuple[int, bool]] = field(default_factory=Counter)
    conditions: Counter[tuple[int, int]] = field(default_factory=Counter)
    #: how many cycles ran as this one did
    count: int = 1

    def add(self, other: _Record, times: int = 1) -> None:
        """``other``'s hits, ``times`` over."""
        self.lines.update({key: hits * times for key, hits in other.lines.items()})
        self.branches.update({key: hits * times for key, hits in other.branches.items()})
        self.conditions.update({key: hits * times for key, hits in other.conditions.items()})


class Collector:
    """Collects the coverage of ``runner``'s cycles (install with ``attach``). The master
    skips the cycles that would repeat the last one; with ``counts`` each one it skipped
    counts as the last one run (``repeated``, which the board calls), so the hit counts
    are the program cycles that ran each line; without, what ran and which outcomes were
    seen stay exact and the hit counts count only the cycles the emulator ran."""

    def __init__(
        self, runner: ProgramRunner, line_map: LineMap, program: Program, *,
        counts: bool = True,
    ) -> None:
        self.runner = runner
        self.counts = counts
        self._view = ProgramView(runner, lambda _: 0)
        files = {PurePath(m.file).name: os.path.abspath(m.file) for m in program.modules()}
        self._lines: list[LineKey] = []
        self._branches: list[LineKey] = []
        self._conditions: list[ConditionKey] = []
        self._points: dict[int, _Point] = {}
        first: dict[SourceLine, int] = {}
        for address, line in sorted(line_map.line_starts().items()):
            first.setdefault(line, address)
        for module in program.modules():
            path = files[PurePath(module.file).name]
            for node in module.code():
                span = node.span
                if span is None or isinstance(node, ast.Label | ast.SegmentEnd):
                    continue
                start = first.get(SourceLine(PurePath(span.file).name, span.line))
                if start is None or start in self._points:
                    continue  # no code of its own
                self._points[start] = self._point(path, node)
        #: the timers' remaining counts, which the tick changes every 10 ms: a cycle does
        #: not depend on them (only on the status bits) unless the program reads one (the
        #: image says which: ``ProgramMap.unread_timers``)
        pmap = runner.pmap
        self._data = (layout.DATA_BASE, pmap.data_end)
        self._unread = [address - layout.DATA_BASE for n, address in pmap.timers.items()
                        if n in pmap.unread_timers
                        and layout.DATA_BASE <= address < pmap.data_end - 1]
        self._records: dict[bytes, _Record] = {}
        #: what the cycles that called firmware blocks did, added up (never reused)
        self._once = _Record()
        self._watching: tuple[bytes | None, _Record] | None = None
        #: the last cycle's record (what a cycle the master skips as a repeat did), and
        #: the last one added to ``_once`` rather than kept
        self._last: _Record | None = None
        self._once_last: _Record | None = None
        self._calls = 0

    def _point(self, path: str, node: ast.Statement | ast.GatingLine) -> _Point:
        span = node.span
        assert span is not None
        self._lines.append((path, span.line))
        branch = -1
        if (isinstance(node, ast.Jump | ast.CallFB) and node.conditional) or (
            isinstance(node, ast.BlockEnd) and node.kind is ast.EndKind.BEC
        ):
            branch = len(self._branches)
            self._branches.append((path, span.line))
        reads: list[ast.Operand] = []
        if isinstance(node, ast.Logic):
            reads = [node.operand]
        elif isinstance(node, ast.GatingLine):
            reads = [term.operand for term in node.terms]
        conditions = []
        for operand in reads:
            if operand.width is not ast.Width.BIT or operand.kind in ast.CONSTANTS:
                continue
            where = operand.span or span
            conditions.append((len(self._conditions), Operand(operand)))
            self._conditions.append((path, where.line, where.column, str(operand)))
        return _Point(len(self._lines) - 1, branch, tuple(conditions))

    # ------------------------------------------------------------------ watching

    def attach(self) -> None:
        self.runner.watch = self.watch

    def watch(self, inputs: bytes | bytearray | None) -> Trace | None:
        """Before each cycle (``ProgramRunner.watch``): the trace for a cycle from a new
        state, None for one whose record is known."""
        self._close()
        firmware = self.runner.firmware
        if firmware is not None and hasattr(firmware, "calls"):
            self._calls = firmware.calls
        state = self._state(inputs)
        if state is not None:
            known = self._records.get(state)
            if known is not None:
                known.count += 1
                self._last = known
                return None
        record = _Record()
        self._watching = (state, record)
        return self._tracer(record)

    def repeated(self, cycles: int) -> None:
        """``cycles`` program cycles the master did not run, each one the same as the
        last one run (``Pc2Board.repeated``, set when ``counts`` is): they count as it."""
        self._close()
        last = self._last
        if last is None:
            return
        if last is self._once_last:  # not kept by its state: its hits added up again
            self._once.add(last, cycles)
        else:
            last.count += cycles

    def _state(self, inputs: bytes | bytearray | None) -> bytes | None:
        runner = self.runner
        cpu = runner.cpu
        if not cpu.xdata.plain:
            return None
        ram = cpu.xdata.ram
        start, end = self._data
        data = ram[start:end]
        for offset in self._unread:
            data[offset] = data[offset + 1] = 0
        return b"".join((
            cpu.iram, cpu.sfr, runner.inputs, inputs or b"", ram[: layout.DPRAM_SIZE], data,
        ))

    def _tracer(self, record: _Record) -> Trace:
        points = self._points
        view = self._view
        sfr = self.runner.cpu.sfr
        lines, branches, conditions = record.lines, record.branches, record.conditions

        def trace(cpu: Emulator, address: int) -> None:
            point = points.get(address)  # the line's first instruction has just run
            if point is None:
                return
            lines[point.line] += 1
            if point.branch >= 0:
                branches[point.branch, bool(sfr[_PSW] & _CARRY)] += 1
            for index, operand in point.conditions:
                conditions[index, view.read(operand)] += 1

        return trace

    def _close(self) -> None:
        """The watched cycle is over: keep its record (for its state, unless it called a
        firmware block)."""
        if self._watching is None:
            return
        state, record = self._watching
        self._watching = None
        firmware = self.runner.firmware
        called = firmware is not None and getattr(firmware, "calls", 0) != self._calls
        if state is None or called or len(self._records) >= MAX_RECORDS:
            self._once.add(record)
            self._once_last = record
        else:
            self._records[state] = record
        self._last = record

    # ------------------------------------------------------------------ the result

    def coverage(self) -> Coverage:
        self._close()
        lines = [0] * len(self._lines)
        branches = [[0, 0] for _ in self._branches]
        conditions = [[0, 0] for _ in self._conditions]
        for record in (*self._records.values(), self._once):
            n = record.count
            for index, hits in record.lines.items():
                lines[index] += hits * n
            for (index, taken), hits in record.branches.items():
                branches[index][0 if taken else 1] += hits * n
            for (index, value), hits in record.conditions.items():
                conditions[index][value] += hits * n
        return Coverage(
            dict(zip(self._lines, lines, strict=True)),
            dict(zip(self._branches, branches, strict=True)),
            dict(zip(self._conditions, conditions, strict=True)),
        )
