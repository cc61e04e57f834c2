"""A simulation's IL coverage, as an observer (sim/observer.py): a collector
(observe/coverage.py) on the program's runner once the program is loaded, and on each
runner a reload makes; at the end the collectors' coverage merged into the result.
sim/coverage.py writes the reports.
"""

from __future__ import annotations

from asictl.board.board import Pc2Board
from asictl.il.loader import Program
from asictl.observe.coverage import Collector, Coverage
from asictl.runtime.line_map import LineMap
from asictl.sim.observer import Observer
from asictl.sim.result import SimResult


class CoverageWatch(Observer):
    """The coverage of ``program`` on ``board``; ``counts``: exact hit counts (the cycles
    the board skips as repeats of the last one counted as that one)."""

    def __init__(self, board: Pc2Board, line_map: LineMap, program: Program, *,
                 counts: bool) -> None:
        self._board = board
        self._line_map = line_map
        self._program = program
        self._counts = counts
        self._collectors: list[Collector] = []

    def loaded(self) -> None:
        self._watch()

    def after_any_cycle(self) -> None:
        collectors = self._collectors
        if not collectors or collectors[-1].runner is not self._board.program:
            self._watch()

    def finish(self, result: SimResult) -> None:
        result.coverage = Coverage()
        for collector in self._collectors:
            result.coverage.merge(collector.coverage())

    def _watch(self) -> None:
        """Collect coverage from the runner now loaded (a reload makes a new one)."""
        runner = self._board.program
        if runner is None:
            return
        if self._collectors and self._collectors[-1].runner is runner:
            return
        collector = Collector(runner, self._line_map, self._program, counts=self._counts)
        collector.attach()
        if self._counts:
            self._board.repeated = collector.repeated
        self._collectors.append(collector)
