"""What a simulation records as it runs: the signals of its trace (``--trace``) and the
per-line IL trace (``--trace-il``). sim.trace is the trace itself and its three forms
(VCD, CSV, a timing diagram).

The signals are the operands the program uses (for an image without its source: what
its program map names) and whether the program runs, each sampled after every AS-i
cycle that ran; ``--signals`` picks some of them by shell patterns. The per-line trace
has its line hooks on only inside its time window, as they slow the program down.
"""

from __future__ import annotations

import fnmatch
import functools
from collections.abc import Callable
from typing import assert_never

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
from asictl.sim.trace import Signal

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


class LineTrace:
    """The per-line trace of one run on ``board``; ``clock`` is master time since time 0
    (0 before the first cycle)."""

    def __init__(
        self, board: Pc2Board, texts: dict[str, str], program: Program | None,
        line_map: LineMap, window: tuple[float, float | None], clock: Callable[[], float],
    ) -> None:
        self.board = board
        self.texts = texts
        self.program = program
        self.line_map = line_map
        self.window = window
        self._clock = clock
        self._tracer: ILTracer | None = None

    def switch(self, on: bool, view: Callable[[], ProgramView]) -> None:
        """Switch the per-line trace on or off (it slows the program down while on)."""
        runner = self.board.program
        if runner is None:
            return
        if self._tracer is None:
            self._tracer = ILTracer(
                runner, self.line_map, texts=self.texts,
                clock=self._clock,
                view=view(), operands=line_operands(self.program),
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

