"""What a simulation records as it runs, as two observers (sim/observer.py): the
signals of its trace (``--trace``, ``SignalTrace``) and the per-line IL trace
(``--trace-il``, ``LineTrace``). sim.trace is the trace itself and its three forms (VCD,
CSV, a timing diagram).

The signals are the operands the program uses (for an image without its source: what
its program map names) and whether the program runs, each sampled after every AS-i
cycle that ran; ``--signals`` picks some of them by shell patterns. The per-line trace
has its line hooks on only inside its time window, as they slow the program down.
"""

from __future__ import annotations

import fnmatch
import functools
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, assert_never

from asictl.board.board import Pc2Board
from asictl.il import ast
from asictl.il.loader import Program
from asictl.image.eeprom import ProgramImage
from asictl.observe.iltrace import ILTracer, LineRow, line_operands
from asictl.observe.operands import Operand, parse_operand
from asictl.observe.symbols import SymbolTable
from asictl.observe.view import ProgramView, wake
from asictl.runtime.line_map import LineMap
from asictl.runtime.program_map import CellKind
from asictl.sim.observation import Stop
from asictl.sim.observer import BEFORE_MS, Observer
from asictl.sim.plant import Model
from asictl.sim.result import SimResult
from asictl.sim.trace import Mark, Signal, Trace

if TYPE_CHECKING:  # the engine imports this module
    from asictl.sim.engine import Simulation

#: The name of the lane that shows whether the program runs.
RUNNING = "program running"

#: How one signal is sampled: its value now.
Sample = Callable[[], int]


class Signals:
    """The signals of a trace and how each is sampled; ``read`` gives an operand's
    value, ``running`` whether the program runs (1) or not (0); ``extra`` are lanes of
    their own (plant models' state), ``inputs`` operands to trace besides the program's."""

    def __init__(
        self, program: Program | None, image: ProgramImage, symbols: SymbolTable,
        patterns: list[str] | None, read: Callable[[Operand], int], running: Sample,
        extra: list[tuple[Signal, Sample]] | None = None, inputs: list[str] | None = None,
    ) -> None:
        self.symbols = symbols
        self._read = read
        self._running = running
        #: what a trace cannot show, in words (an image without its source)
        self.untraced = ""
        if program is not None:
            names = _trace_names(program)
        else:
            names = _image_names(image)
            self.untraced = (
                "the image carries no source: the trace shows the operands its program "
                "map names (inputs and outputs of its slaves, the flag bytes it keeps "
                "in internal RAM, its timers and counters), not the flags it keeps in "
                "the communication memory"
            )
        if inputs:  # the inputs plant models drive, whether the program reads them or not
            known = set(names)
            names = [*(n for n in inputs if n not in known), *names]
        self._operands: dict[int, Operand] = {}
        self.sampled = _select(self._make_signals(names) + list(extra or []), patterns)
        #: the operands the sampled signals read
        self.operands = [self._operands[id(s)] for s, _ in self.sampled if id(s) in self._operands]

    def _make_signals(self, names: list[str]) -> list[tuple[Signal, Sample]]:
        signals: list[tuple[Signal, Sample]] = []
        for name in names:
            if name == RUNNING:
                signals.append((Signal(RUNNING, 1, operand=RUNNING), self._running))
                continue
            operand = parse_operand(name)
            signal = Signal(self.symbols.label(name), operand.width, operand=name)
            self._operands[id(signal)] = operand
            signals.append((signal, functools.partial(self._read, operand)))
        return signals


def stop_marks(stops: list[Stop]) -> list[Mark]:
    """The stops of a run as marks on the lane that shows whether the program runs."""
    return [Mark(s.at_ms, f"stopped: {s.text}", RUNNING) for s in stops]


class SignalTrace(Observer):
    """The trace of one simulation: its signals (``patterns``: ``--signals``), the plant
    models' lanes and the inputs they drive, sampled after every AS-i cycle that ran and
    at every change of a model."""

    def __init__(self, simulation: Simulation, patterns: list[str] | None) -> None:
        self._simulation = simulation
        plant = simulation.plant
        lanes = [(Signal(lane.name, lane.width, operand=lane.name), lane.sample)
                 for lane in plant.lanes()]
        traced = Signals(simulation.program, simulation.image, simulation.symbols, patterns,
                         simulation.read, lambda: int(simulation.running), lanes,
                         [str(o) for m in plant.models for o in m.driven()])
        self.signals, self.untraced = traced.sampled, traced.untraced
        #: the operands sampled after every cycle that runs
        self._operands = traced.operands

    def trace(self, end_ms: float, marks: list[Mark]) -> Trace:
        return Trace([s for s, _ in self.signals], end_ms=end_ms,
                     marks=sorted(marks, key=lambda m: m.at_ms))

    def active(self) -> bool:
        return bool(self.signals)

    def sampled(self) -> Iterable[Operand]:
        return self._operands

    def model_added(self, model: Model) -> None:
        """The inputs a new model drives join the trace, unless traced already, and its
        lanes."""
        simulation = self._simulation
        known = {signal.operand for signal, _ in self.signals}
        for operand in model.driven():
            if str(operand) not in known:
                name = simulation.symbols.label(str(operand))
                self.signals.append((Signal(name, operand.width, operand=str(operand)),
                                     functools.partial(simulation.read, operand)))
        self.signals += [(Signal(lane.name, lane.width, operand=lane.name), lane.sample)
                         for lane in model.lanes()]

    def after_cycle(self, now: float) -> None:
        for signal, read in self.signals:
            signal.record(now, read())

    def changed(self, at: float) -> None:
        self.after_cycle(at)

    def finish(self, result: SimResult) -> None:
        marks = [Mark(f.at_ms, f"{f.written or f.operand} expected {f.expected}, got {f.got}",
                      str(f.operand)) for f in result.failures]
        result.trace = self.trace(self._simulation.end_ms, marks + stop_marks(result.stops))


class LineTrace(Observer):
    """The per-line trace of one run on ``board``, on inside ``window`` (up to ``end_ms``,
    where the run ends); ``clock`` is master time since time 0 (0 before the first
    cycle), ``view`` the program's operands."""

    def __init__(
        self, board: Pc2Board, texts: dict[str, str], program: Program | None,
        line_map: LineMap, window: tuple[float, float | None], clock: Callable[[], float],
        view: Callable[[], ProgramView], end_ms: float,
    ) -> None:
        self.board = board
        self.texts = texts
        self.program = program
        self.line_map = line_map
        self.window = window
        self._clock = clock
        self._view = view
        self._end_ms = end_ms
        self._tracer: ILTracer | None = None

    def times(self) -> Iterable[tuple[float, bool]]:
        """On at the window's start, off after the cycles at its end."""
        start, end = self.window
        edges = {start, None if end is None else end + BEFORE_MS}
        return ((t, False) for t in edges if t is not None and 0 < t <= self._end_ms)

    def begin(self) -> None:
        if self.window[0] <= 0:
            self.switch(True)

    def started(self) -> None:
        end = self.window[1]
        if end is not None and end <= 0:  # a window of time 0 alone: its cycle has run
            self.switch(False)

    def at_time(self, at: float) -> None:
        start, end = self.window
        if at == start:
            self.switch(True)
        if end is not None and at == end + BEFORE_MS:
            self.switch(False)

    def finish(self, result: SimResult) -> None:
        self.switch(False)
        result.il_rows = self.rows

    def switch(self, on: bool) -> None:
        """Switch the per-line trace on or off (it slows the program down while on)."""
        runner = self.board.program
        if runner is None:
            return
        if self._tracer is None:
            self._tracer = ILTracer(
                runner, self.line_map, texts=self.texts,
                clock=self._clock,
                view=self._view(), operands=line_operands(self.program),
                window=self.window,
            )
        if on:
            self._tracer.hooks.install()
            wake(self.board)
        else:
            self._tracer.hooks.remove()

    @property
    def rows(self) -> list[LineRow]:
        return self._tracer.rows if self._tracer is not None else []


def _select(
    signals: list[tuple[Signal, Sample]], patterns: list[str] | None
) -> list[tuple[Signal, Sample]]:
    """The signals ``--signals`` asks for (shell patterns on lane or operand names), in
    the order of the patterns."""
    if not patterns:
        return signals
    chosen: list[tuple[Signal, Sample]] = []
    for pattern in patterns:
        for item in signals:
            signal = item[0]
            names = (signal.name.casefold(), signal.operand.casefold())
            if item not in chosen and any(fnmatch.fnmatchcase(n, pattern.casefold())
                                          for n in names):
                chosen.append(item)
    return chosen


def _trace_names(program: Program) -> list[str]:
    """Every I and Q bit the program uses, the flags it reads or writes, its timers' and
    counters' status and value, and whether it runs."""
    inputs, outputs, flags = set(), set(), set()
    timers, counters = set(), set()
    K = ast.OperandKind
    for module in program.modules():
        for node in module.code():
            for operand, _ in ast.operands(node):  # (PARAM answers in flag byte 127)
                a, b = operand.address, operand.bit
                match operand.kind:
                    case K.I | K.I2:
                        inputs.add((a, b))
                    case K.Q:
                        outputs.add((a, b))
                    case K.F:
                        flags.add(f"F {a}.{b}")
                    case K.FY:
                        flags.add(f"FY {a}")
                    case K.FW:
                        flags.update((f"FY {a}", f"FY {a + 1}"))
                    case K.T:
                        timers.add(a)
                    case K.C:
                        counters.add(a)
                    case (K.IB | K.I2B | K.QB | K.PSEG | K.VAR | K.KT | K.KC | K.KB | K.KW
                          | K.KP):
                        pass
                    case _:
                        assert_never(operand.kind)
    return (
        [f"I {a}.{b}" for a, b in sorted(inputs)]
        + [f"Q {a}.{b}" for a, b in sorted(outputs)]
        + sorted(flags, key=_flag_order)
        + [name for n in sorted(timers) for name in (f"T {n}", f"TV {n}")]
        + [name for n in sorted(counters) for name in (f"C {n}", f"CV {n}")]
        + [RUNNING]
    )


def _image_names(image: ProgramImage) -> list[str]:
    """What an image's program map names: the I/O bits of the projected slaves its cells
    hold, the flag bytes in cells, the timers and counters."""
    pmap = image.pmap
    projected = set(image.configuration.projected())

    def bits(kinds: tuple[CellKind, ...]) -> list[tuple[int, int]]:
        slaves = {
            address
            for (kind, k), _ in pmap.cells.items() if kind in kinds
            for address in (2 * k, 2 * k + 1) if address in projected
        }
        return [(a, b) for a in sorted(slaves) for b in range(4)]

    return (
        [f"I {a}.{b}" for a, b in bits((CellKind.I, CellKind.I2))]
        + [f"Q {a}.{b}" for a, b in bits((CellKind.Q,))]
        + [f"FY {n}" for kind, n in sorted(pmap.cells) if kind is CellKind.F]
        + [name for n in sorted(pmap.timers) for name in (f"T {n}", f"TV {n}")]
        + [name for n in sorted(pmap.counters) for name in (f"C {n}", f"CV {n}")]
        + [RUNNING]
    )


def _flag_order(name: str) -> tuple[bool, list[int]]:
    return name.startswith("FY"), [int(x) for x in name.split()[1].split(".")]

