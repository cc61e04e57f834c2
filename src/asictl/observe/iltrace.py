"""The per-line trace: one row for every IL line the program executes.

A row is written when the line's code is done, that is when the next line starts (or
the cycle ends), and holds the IL registers at that moment: the single-bit register,
ACCU1 and ACCU2, and the value of the line's operand. A line that calls a function block
is done when the block's first line starts; the block's lines follow it. Lines without
code (labels, ``***``) have no rows.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import PurePath

from asictl.il import ast
from asictl.il.loader import Program
from asictl.observe.hooks import LineHooks
from asictl.observe.operands import Operand
from asictl.observe.view import ProgramView
from asictl.runtime.line_map import LineMap, SourceLine
from asictl.runtime.runner import ProgramRunner

COLUMNS = ("time_ms", "file", "line", "rlo", "accu1", "accu2", "source", "cycle", "operand",
           "constant")


@dataclass(frozen=True)
class LineRow:
    time_ms: float
    cycle: int
    line: SourceLine
    rlo: int
    accu1: int
    accu2: int
    #: the value of the line's operand after it ran (None: the line has none to show)
    operand: int | None
    source: str
    #: the constant register (what L KT, L KC and L KP loaded last: they leave both
    #: accumulators alone)
    constant: int = 0


def line_operands(program: Program | None) -> dict[SourceLine, Operand]:
    """The operand each IL line works on, as a scenario would name it (a gating line: its
    target; a count, or a timer or counter loaded or transferred: ``CV n``, ``TV n``)."""
    found: dict[SourceLine, Operand] = {}
    if program is None:
        return found
    for module in program.modules():
        for node in module.code():
            operand = _operand_of(node)
            if node.span is not None and operand is not None:
                found[SourceLine(PurePath(node.span.file).name, node.span.line)] = operand
    return found


def _operand_of(node: ast.Statement | ast.GatingLine) -> Operand | None:
    """The operand the source shows (not PARAM's answer), if it is one a view reads."""
    uses = ast.operands(node)
    if not uses or isinstance(node, ast.Param):
        return None
    operand = uses[0][0]
    if operand.kind in ast.CONSTANTS or operand.kind is ast.OperandKind.FW:
        return None
    return Operand(operand)


class ILTracer:
    """Records ``LineRow``s of a runner's cycles while ``active()`` says so."""

    def __init__(
        self,
        runner: ProgramRunner,
        line_map: LineMap,
        *,
        texts: Mapping[str, str],
        clock: Callable[[], float],
        view: ProgramView,
        operands: Mapping[SourceLine, Operand] | None = None,
        window: tuple[float, float | None] = (0.0, None),
    ) -> None:
        self.line_map = line_map
        self.clock = clock
        self.view = view
        self.operands = operands or {}
        self.window = window
        self._lines = {PurePath(name).name: text.split("\n") for name, text in texts.items()}
        self.rows: list[LineRow] = []
        self.cycle = 0
        #: the last cycle whose end was seen (its rows are complete)
        self.completed = 0
        self._pending: SourceLine | None = None
        self.hooks = LineHooks(
            runner, line_map, on_line=self._line, on_cycle_start=self._cycle_start,
            on_cycle_end=self._cycle_end,
        )

    def source(self, line: SourceLine) -> str:
        lines = self._lines.get(line.file)
        if lines is None or not 0 < line.line <= len(lines):
            return ""
        return lines[line.line - 1].partition(";")[0].strip()

    def _cycle_start(self) -> None:
        self.cycle += 1
        self._pending = None

    def _cycle_end(self) -> None:
        self._flush()
        self.completed = self.cycle

    def _line(self, line: SourceLine, address: int) -> None:
        self._flush()
        self._pending = line

    def _flush(self) -> None:
        line = self._pending
        if line is None:
            return
        self._pending = None
        now = self.clock()
        start, end = self.window
        if now < start or (end is not None and now > end):
            return
        view = self.view
        operand = self.operands.get(line)
        self.rows.append(LineRow(
            now, self.cycle, line, view.rlo, view.accu1, view.accu2,
            None if operand is None else view.read(operand), self.source(line),
            view.constant,
        ))


def to_csv(rows: list[LineRow]) -> str:
    """``time_ms,file,line,rlo,accu1,accu2,source,cycle,operand,constant``, one row a
    line (the constant register last, so that the columns before it stay where they
    were)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(COLUMNS)
    for row in rows:
        writer.writerow([
            f"{row.time_ms:g}", row.line.file, row.line.line, row.rlo, row.accu1, row.accu2,
            row.source, row.cycle, "" if row.operand is None else row.operand, row.constant,
        ])
    return buffer.getvalue()
