"""A scenario's expectations, as two observers of a simulation (sim/observer.py).

``Expectations`` checks the steps without a tolerance window at their time, against the
state the cycles that started before it left. ``Windows`` decides the steps with a
``within_ms`` when their window closes: each expectation holds if its value was seen at
the window's edges or after any AS-i cycle that ran in it; with ``track_writers`` it
also names the IL line that last wrote each expected operand before the step's time.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import PurePath
from typing import TYPE_CHECKING

from asictl.il import ast
from asictl.mcs51.emulator import Emulator
from asictl.observe.operands import Operand
from asictl.runtime.line_map import SourceLine
from asictl.sim.observer import Observer
from asictl.sim.result import Failure, SimResult
from asictl.sim.scenario import Step

if TYPE_CHECKING:  # the engine imports this module
    from asictl.sim.engine import Simulation


class Expectations(Observer):
    """The expectations of the steps without a tolerance window, checked at their time."""

    def __init__(self, read: Callable[[Operand], int], result: SimResult) -> None:
        self._read = read
        self._result = result

    def after_steps(self, steps: list[Step]) -> None:
        result = self._result
        for step in steps:
            if step.within_ms:  # decided by its window
                continue
            written = step.written
            for operand, expected, line in step.expect:
                result.checked += 1
                got = self._read(operand)
                if got != expected:
                    result.failures.append(Failure(
                        step, line, operand, expected, got, written.get((line, str(operand)), "")
                    ))


@dataclass
class _Window:
    """The tolerance window of one step's expectations: which held at some moment in it
    (after an AS-i cycle that ran, at its edges), the values at the step's own time."""

    step: Step
    closes_at: float
    held: set[int] = field(default_factory=set)
    got: dict[int, int] = field(default_factory=dict)
    writers: dict[int, str] = field(default_factory=dict)

    def sample(self, read: Callable[[Operand], int]) -> None:
        for index, (operand, expected, _) in enumerate(self.step.expect):
            if index not in self.held and read(operand) == expected:
                self.held.add(index)


class Windows(Observer):
    """The expectations of the steps with a tolerance window (``steps``: those the run
    reaches), decided when each window closes."""

    def __init__(self, simulation: Simulation, steps: Iterable[Step], *,
                 track_writers: bool) -> None:
        self._read = simulation.read
        self._result = simulation.result
        #: the windows by the times they open and close; those open now
        self._opens: dict[float, list[Step]] = {}
        self._closes: dict[float, list[Step]] = {}
        windowed = [step for step in steps if step.within_ms and step.expect]
        for step in windowed:
            self._opens.setdefault(max(0.0, step.at_ms - step.within_ms), []).append(step)
            self._closes.setdefault(step.at_ms + step.within_ms, []).append(step)
        self._open: dict[int, _Window] = {}
        self._writers = _Writers(simulation, windowed) if track_writers else None

    def active(self) -> bool:
        return bool(self._opens)

    def times(self) -> Iterable[tuple[float, bool]]:
        return ((at, True) for at in (*self._opens, *self._closes))

    def sampled(self) -> Iterable[Operand]:
        return (o for steps in self._opens.values() for s in steps for o, _, _ in s.expect)

    def loaded(self) -> None:
        if self._writers is not None:
            self._writers.install()

    def begin(self) -> None:
        self._open_at(0.0)

    def at_time(self, at: float) -> None:
        self._close(at)
        self._open_at(at)

    def after_steps(self, steps: list[Step]) -> None:
        read = self._read
        for step in steps:
            window = self._open.get(id(step))
            if window is None:
                continue
            window.sample(read)
            for index, (operand, _, _) in enumerate(step.expect):
                window.got[index] = read(operand)
                if self._writers is not None:
                    window.writers[index] = self._writers.last(operand)

    def after_cycle(self, now: float) -> None:
        for window in self._open.values():
            window.sample(self._read)

    def finish(self, result: SimResult) -> None:
        self._close(None)

    def _open_at(self, at: float) -> None:
        for step in self._opens.get(at, []):
            window = _Window(step, step.at_ms + step.within_ms)
            window.sample(self._read)
            self._open[id(step)] = window

    def _close(self, at: float | None) -> None:
        """Decide the windows closing at ``at`` (None: all still open, at the end)."""
        for key, window in list(self._open.items()):
            if at is not None and window.closes_at != at:
                continue
            del self._open[key]
            window.sample(self._read)
            step = window.step
            for index, (operand, expected, line) in enumerate(step.expect):
                self._result.checked += 1
                if index not in window.held:
                    self._result.failures.append(Failure(
                        step, line, operand, expected, window.got.get(index, 0),
                        step.written.get((line, str(operand)), ""),
                        window.writers.get(index, ""),
                    ))


def _cells(node: ast.Operand) -> set[tuple[str, int, int]]:
    """The bits (or, for the rest, the whole operand) an IL operand covers, to find the
    lines that write an operand a scenario expects: ``Q 2.1`` is written by ``= Q 2.1``
    and by ``T QB 2``."""
    K = ast.OperandKind
    n, b = node.address, node.bit
    letter = {K.I: "I", K.IB: "I", K.Q: "Q", K.QB: "Q", K.F: "F", K.FY: "F", K.FW: "F"}
    kind = letter.get(node.kind)
    if kind is None:
        return {(f"{node.kind.value}{node.name}", n, b)}
    if node.kind in (K.I, K.Q):
        return {(kind, n, b)} if b >= 0 else {(kind, n, i) for i in range(4)}
    if node.kind in (K.IB, K.QB):
        return {(kind, a, i) for a in (n, n + 1) for i in range(4)}
    if node.kind is K.F:
        return {(kind, n, b)}
    size = 2 if node.kind is K.FW else 1
    return {(kind, y, i) for y in range(n, n + size) for i in range(8)}


class _Writers:
    """Which IL line last wrote each operand a tolerance window expects: a trap at the
    start of each line that writes one (an S or R only while the register is 1)."""

    def __init__(self, simulation: Simulation, steps: list[Step]) -> None:
        self.simulation = simulation
        self.expected = [operand for step in steps for operand, _, _ in step.expect]
        self._last: dict[str, str] = {}

    def install(self) -> None:
        simulation = self.simulation
        runner, program = simulation.runner, simulation.program
        if runner is None or program is None or not self.expected:
            return
        wanted = {str(o): _cells(o.node) for o in self.expected}
        lines: dict[SourceLine, tuple[ast.Statement | ast.GatingLine, list[str]]] = {}
        for module in program.modules():
            for node in module.code():
                if node.span is None:
                    continue
                written = set().union(*(_cells(o) for o, access in ast.operands(node)
                                        if access is not ast.Access.READ))
                hit = [name for name, cells in wanted.items() if cells & written]
                if hit:
                    lines[SourceLine(PurePath(node.span.file).name, node.span.line)] = (node, hit)
        cpu = runner.cpu
        for address, line in simulation.line_map.line_starts().items():
            if line in lines and address not in cpu.traps:
                node, names = lines[line]
                cpu.add_trap(address, self._trap(line, node, names))

    def _trap(self, line: SourceLine, node: ast.Statement | ast.GatingLine,
              names: list[str]) -> Callable[[Emulator], None]:
        conditional = isinstance(node, ast.Store) and node.op is not ast.StoreOp.ASSIGN
        text = str(line)

        def trap(cpu: Emulator) -> None:
            if conditional and not self.simulation.view().rlo:
                return  # an S or R that writes nothing
            for name in names:
                self._last[name] = text

        return trap

    def last(self, operand: Operand) -> str:
        return self._last.get(str(operand), "")
