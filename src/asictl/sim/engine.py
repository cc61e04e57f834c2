"""Running a scenario: a program on a fresh emulated master, in virtual time.

The program's image (built by ``asictl.build`` from source, an uploaded [RAW] file or a
.hex image) is downloaded through the same driver and commands as ``asictl download``
(so the simulation exercises what the plant would get), then the scenario's steps are
applied at their times.

The timing contract (docs/simulation.md): **time 0 is the master time of the first
program cycle**. The download leaves the program loaded but stopped; the steps at time 0
are applied (and its expectations checked, against the state before any cycle) while
nothing runs; then the host sets the start flag and the master runs the first cycle in
the AS-i cycle that executes the command. From then on a ``set`` at T takes effect for
every program cycle that starts at or after T, and an ``expect`` at T checks the state
left by the cycles that started before T; at equal times sets come before checks.

This module is the stepping core: it downloads, applies the steps' sets at their times
and lets master time pass. Everything else is an observer (sim/observer.py) that the
core calls at its hooks, in this order: the stops and firmware refusals
(sim/observation.py), the plant models (sim/closed_loop.py: evaluated after every AS-i
cycle that ran and at each model's own next change; a model that will change an input
sooner than the current ``advance`` was planned to end pauses the board there), the
expectations and their tolerance windows (sim/expectations.py), the trace and the
per-line trace (sim/tracing.py) and the coverage (sim/coverage_watch.py).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from pathlib import PurePath
from typing import Any

from asictl.board.asi import AsiBus, Slave
from asictl.board.board import Pc2Board
from asictl.build import Build
from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity, Span
from asictl.host.transfer import Pc2Transport, StartMode, download
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.il import ast
from asictl.il.loader import Program
from asictl.image.eeprom import ProgramImage
from asictl.observe.operands import Operand
from asictl.observe.symbols import SymbolTable
from asictl.observe.view import ProgramView, host_write, read_on_board
from asictl.platform import pc2 as d
from asictl.platform.master import IO_CODE_BITS, ControlFlag
from asictl.readers.units import format_instant
from asictl.runtime.line_map import LineMap
from asictl.runtime.program_map import ProgramMap
from asictl.runtime.runner import ProgramRunner
from asictl.sim.closed_loop import ClosedLoop
from asictl.sim.coverage_watch import CoverageWatch
from asictl.sim.expectations import Expectations, Windows
from asictl.sim.observation import Observation
from asictl.sim.observer import BEFORE_MS, Observer
from asictl.sim.plant import Model, Plant
from asictl.sim.result import FinalState, SimResult
from asictl.sim.scenario import Scenario, SlaveSpec, Step
from asictl.sim.trace import Trace
from asictl.sim.tracing import LineTrace, SignalTrace, stop_marks

__all__ = ["PROGRESS_MS", "SimResult", "Simulation", "line_map_of", "source_texts",
           "variables_of"]

#: The master's power-up: it finds its slaves before the host downloads.
_POWER_UP_MS = 100.0
#: How long the master may take after the start command to run the first cycle.
_START_WAIT_MS = 1000.0
#: How often a trace samples a moving plant model without a cycle period of its own.
_SAMPLE_MS = 10.0
#: How much master time passes between two reports to a simulation's ``progress``.
PROGRESS_MS = 1000.0


def _slave(spec: SlaveSpec) -> Slave:
    return Slave(spec.address, spec.io_code, spec.id_code)


def _setup_slaves(image: ProgramImage) -> list[SlaveSpec]:
    return [
        SlaveSpec(s.address, s.io_code, s.id_code, s.parameter)
        for s in image.configuration.slaves()
    ]


def variables_of(pmap: ProgramMap) -> dict[str, int]:
    """A program's variables as scenarios name them: key name -> size in bytes."""
    return {name: variable.size for name, variable in pmap.variables.items()}


def line_map_of(build: Build) -> LineMap:
    """Which IL line each code address implements: the compiler's own knowledge for a
    source file, else what the image carries (nothing for images of format version 1)."""
    if build.compiled is not None:
        return build.compiled.line_map
    return build.image.line_map if build.image is not None else LineMap()


def source_texts(build: Build) -> dict[str, str]:
    """Source file base name -> text, for showing IL lines (from the image when it
    carries its source)."""
    texts = {PurePath(name).name: text for name, text in build.texts.items()}
    if not texts and build.image is not None:
        for name, raw in build.image.program_sources().items():
            texts[name] = raw.decode("latin-1").replace("\r\n", "\n")
    return texts


class Simulation:
    """One scenario on one fresh master, running the image of one build."""

    def __init__(
        self,
        build: Build,
        scenario: Scenario,
        *,
        duration_ms: float | None = None,
        trace: bool = False,
        signals: list[str] | None = None,
        symbols: SymbolTable | None = None,
        il_trace: bool = False,
        window: tuple[float, float | None] = (0.0, None),
        track_writers: bool = False,
        coverage: bool = False,
        coverage_counts: bool = True,
        fail_fast: bool = False,
        progress: Callable[[float, float], None] | None = None,
    ) -> None:
        """``track_writers``: note which IL line last wrote each operand the steps with
        a tolerance window expect (it costs a trap at each line that writes one).
        ``coverage``: collect the IL coverage, with exact hit counts unless
        ``coverage_counts`` is False. ``fail_fast``: end the run at the first failed
        expectation (what mutation testing needs). ``progress(now_ms, end_ms)`` hears,
        every ``PROGRESS_MS`` of master time, how far the run is (a long simulation's
        progress line)."""
        if build.image is None:
            raise ValueError("a simulation needs a build with an image")
        self.build = build
        self.image = build.image
        self.scenario = scenario
        self.symbols = symbols or SymbolTable()
        self.end_ms = duration_ms if duration_ms is not None else scenario.end_ms
        specs = scenario.slaves if scenario.slaves is not None else _setup_slaves(self.image)
        self.board = Pc2Board(bus=AsiBus([_slave(s) for s in specs]))
        self.result = SimResult(scenario)
        self.line_map = line_map_of(build)
        self.program: Program | None = build.source_program()
        self.fail_fast = fail_fast
        self._progress = progress
        #: master time of the first program cycle (0.0 until the download, None until it)
        self._t0: float | None = 0.0
        #: whether the program runs, as the last AS-i cycle left it
        self.running = True
        #: where the current ``advance`` ends, and whether an observer paused it before
        self._limit = math.inf
        self._paused = False
        self._by_time: dict[float, list[Step]] = {}
        for step in scenario.ordered():
            if step.at_ms <= self.end_ms:
                self._by_time.setdefault(step.at_ms, []).append(step)
        steps = [step for steps in self._by_time.values() for step in steps]

        self._loop = ClosedLoop(  # the scenario's models are copies: it may run again
            self, Plant(copy.deepcopy(scenario.plants)),
            (scenario.cycle_ms or _SAMPLE_MS) if trace else None,
        )
        self.plant = self._loop.plant
        self._trace = SignalTrace(self, signals) if trace else None
        #: what a trace cannot show, in words (an image without its source)
        self.untraced = self._trace.untraced if self._trace is not None else ""
        observers: list[Observer] = [
            Observation(self.board, self.line_map, self._since_start, self.result.stops),
            self._loop,
            Windows(self, steps, track_writers=track_writers),
            Expectations(self.read, self.result),
        ]
        if self._trace is not None:
            observers.append(self._trace)
        if il_trace:
            observers.append(LineTrace(self.board, source_texts(build), self.program,
                                       self.line_map, window, self._since_start, self.view,
                                       self.end_ms))
        if coverage and self.program is not None:
            observers.append(CoverageWatch(self.board, self.line_map, self.program,
                                           counts=coverage_counts))
        #: every observer, and from ``begin`` on the active ones
        self._observers = observers
        #: the hooks called after each cycle or change, chosen at ``begin``
        self._after_any_cycle: list[Callable[[], None]] = []
        self._after_cycle: list[Callable[[float], None]] = []
        self._next_changes: list[Callable[[], float | None]] = []
        self._changed: list[Callable[[float], None]] = []

        times = {(at, True) for at in self._by_time}.union(
            *(o.times() for o in observers))
        #: the times at which observers or steps act (ended just before, for the
        #: ``_early`` ones), in order; the next one to come; the last one done
        self._early = {at for at, early in times if early}
        self._events = sorted({at for at, _ in times})
        self._next_event = 0
        self._done_ms = -1.0
        self._tick_exactly()

    def _tick_exactly(self) -> None:
        """The timers whose remaining time is sampled after every cycle that runs (by the
        trace, a tolerance window, a plant model) tick one by one on the board: a step
        over the ticks of an unread timer would hide the values between."""
        sampled = [o for observer in self._observers for o in observer.sampled()]
        self.board.tick_exactly({o.node.address for o in sampled
                                 if o.node.kind is ast.OperandKind.T
                                 and o.node.width is not ast.Width.BIT})

    def _call(self, hook: str, *args: object) -> None:
        """Call one hook of every observer (of every active one once the program runs)."""
        for observer in self._observers:
            getattr(observer, hook)(*args)

    def _choose_hooks(self) -> None:
        """Once the program is to run: the active observers, and the hooks called after
        each cycle or change that they define, so that a feature a run does not use costs
        nothing there."""
        self._observers = active = [o for o in self._observers if o.active()]

        def defined(name: str) -> list[Callable[..., Any]]:
            return [getattr(o, name) for o in active
                    if getattr(type(o), name) is not getattr(Observer, name)]

        self._after_any_cycle = defined("after_any_cycle")
        self._after_cycle = defined("after_cycle")
        self._next_changes = defined("next_change_ms")
        self._changed = defined("changed")

    # ------------------------------------------------------------------ reading

    def now_ms(self) -> float:
        """Master time since time 0 (whole microseconds, so the sum is exact)."""
        return (round(self.board.now_ms * 1000) - round((self._t0 or 0.0) * 1000)) / 1000

    def _since_start(self) -> float:
        """Master time since time 0, and 0 before the first cycle."""
        return self.now_ms() if self._t0 is not None else 0.0

    @property
    def runner(self) -> ProgramRunner | None:
        return self.board.program

    def view(self) -> ProgramView:
        """Operands as the program sees them (its cells inside a cycle)."""
        runner = self.runner
        assert runner is not None
        return ProgramView(runner, self.read)

    def read(self, operand: Operand) -> int:
        """An operand's value now (``read_on_board``): inputs as the slaves deliver them,
        outputs as the program's output image holds them, flags from the communication
        memory, the rest from the program's memory."""
        return read_on_board(self.board, operand)

    # ------------------------------------------------------------------ writing

    def set(self, operand: Operand, value: int, *, step: Step | None = None,
            line: int = 1) -> None:
        """Set an input (as the slave delivers it) or a flag (as a host writes it)."""
        node = operand.node
        n, b = node.address, node.bit
        if node.kind is ast.OperandKind.I:
            slave = self._need_slave(n, step, line, str(operand))
            slave.inputs = value if b < 0 else slave.inputs & ~(1 << b) | value << b  # (I n)
        elif node.kind is ast.OperandKind.IB:
            for address, nibble in ((n, value & 0xF), (n + 1, value >> 4)):
                if nibble or self.board.bus.at(address):
                    self._need_slave(address, step, line, str(operand)).inputs = nibble
        elif node.kind is ast.OperandKind.F:
            old = self.board.dpram_byte(d.FLAGS + n)
            self._host_write(d.FLAGS + n, old & ~(1 << b) | value << b)
        elif node.kind is ast.OperandKind.FY:
            self._host_write(d.FLAGS + n, value)
        else:
            raise ValueError(f"'{operand}' cannot be set: only inputs and flags can")

    def add_model(self, model: Model) -> Model:
        """Add a plant model before the run starts (``asictl.testing`` does); its lanes
        join the trace. ``ValueError`` if another model drives one of its inputs or a
        slave of them is not on the bus."""
        if self.started:
            raise ValueError("plant models are added before the program runs")
        self._loop.add(model)
        self._call("model_added", model)
        self._tick_exactly()
        return model

    def evaluate_plant(self) -> None:
        """Evaluate the plant models now, so that their state is as of now for a reader
        (between their changes they are evaluated only after the cycles that ran)."""
        if self.plant.models and self.started:
            self._change(self.now_ms())

    def trace_now(self) -> Trace:
        """The trace recorded so far (empty without ``trace=True``), with the stops."""
        marks = stop_marks(self.result.stops)
        if self._trace is None:
            return Trace([], end_ms=self._since_start(), marks=marks)
        return self._trace.trace(self._since_start(), marks)

    def wake_at(self, at: float) -> None:
        """An observer changes an input at ``at`` (applied as a set at its time): if that
        comes before the current advance was planned to end, the board pauses after the
        cycle that just ran, so that no cycle is skipped past it."""
        if at - BEFORE_MS < self._limit:
            self._paused = True
            self.board.pause()

    def _need_slave(self, address: int, step: Step | None, line: int, what: str,
                    verb: str = "sets") -> Slave:
        slaves = self.board.bus.at(address)
        if not slaves:
            when = f"at {format_instant(step.at_ms)}: " if step is not None else ""
            message = f"{when}'{what}' {verb} slave {address}, which is not on the bus"
            if step is None:
                raise ValueError(message)
            raise DiagnosticError([Diagnostic(
                Severity.ERROR, ScenarioCode.NO_SUCH_SLAVE, message,
                Span(self.scenario.file, line, 1),
            )])
        return slaves[0]

    def _host_write(self, address: int, value: int) -> None:
        host_write(self.board, address, value)

    # ------------------------------------------------------------------ running

    def start(self) -> None:
        """Power up, download, apply the steps at time 0 and start the program: time 0 is
        the master time of its first cycle."""
        self.load()
        self.begin()

    def load(self) -> None:
        """Power up and download the program stopped; wait until the master has its
        slaves in normal operation (at most a second)."""
        board = self.board
        board.advance(_POWER_UP_MS)
        download(Pc2Transport(Pc2Driver(EmulatedPort(board))), self.image, start=StartMode.STOP)
        settled = d.EcFlag.CONFIG_OK | d.EcFlag.NORMAL_OPERATION_ACTIVE
        deadline = board.now_ms + _START_WAIT_MS
        while board.dpram_byte(d.EC_FLAGS) & settled != settled and board.now_ms < deadline:
            board.advance(1.0)  # the master activates the slaves of the new configuration
        if self.scenario.cycle_ms is not None:  # only now: download and start-up need cycles
            board.cycle_period_us = round(self.scenario.cycle_ms * 1000)
        self._call("loaded")
        self._t0 = None

    def begin(self) -> None:
        """Apply the steps at time 0 (and check its expectations against the state before
        any cycle), then set the start flag: time 0 is the master time of the first
        program cycle (or, if the program cannot start within a second, the moment the
        start was given, the stop then being reported at time 0)."""
        board = self.board
        self._choose_hooks()
        self._call("begin")
        self._run_steps(0.0)
        board.observer = self._observe  # notes the first program cycle as time 0
        flags = int(board.control_flags) & ~(ControlFlag.CONTROL_ACTIVE | ControlFlag.RESET)
        self._host_write(d.CONTROL_FLAGS, flags | ControlFlag.START)
        self._host_write(d.COMMAND, d.Command.WRITE_CONTROL_FLAGS)
        deadline = board.now_ms + _START_WAIT_MS + 2 * (self.scenario.cycle_ms or 0.0)
        while self._t0 is None and board.now_ms < deadline:
            board.advance(BEFORE_MS)  # to the microsecond: time 0 is exact
        if self._t0 is None:
            self._t0 = board.now_ms
            self.running = False
            self._call("stopped", 0.0)
        self._call("started")

    @property
    def started(self) -> bool:
        return self._t0 is not None

    def _run_steps(self, at: float) -> None:
        """The steps at one time: all sets (and bus changes) first, then all checks."""
        steps = self._by_time.get(at, [])
        for step in steps:
            self._apply(step)
        if steps:
            self._call("after_steps", steps)
        self._done_ms = max(self._done_ms, at)

    def run(self) -> SimResult:
        self.start()
        self.run_to(self.end_ms)
        return self.finish()

    def _final_state(self) -> FinalState:
        view = self.view()
        pmap = self.image.pmap
        outputs = {
            slave.address: self.board.outputs[slave.address >> 1] >> (slave.address & 1) * 4 & 0xF
            for slave in sorted(self.board.bus.slaves, key=lambda s: s.address)
            if any(letter in "ob" for letter in IO_CODE_BITS[slave.io_code])
        }
        return FinalState(
            self.end_ms, outputs,
            {n: view.counter(n) or 0 for n in sorted(pmap.counters)},
            {n: view.timer_ms(n) or 0 for n in sorted(pmap.timers)},
        )

    def run_to(self, t_ms: float) -> None:
        """Let master time pass up to ``t_ms``, applying the steps and calling the
        observers at their times and changes on the way; the steps at ``t_ms`` are
        applied and its cycles run."""
        events = self._events
        changes = self._next_changes
        while True:
            at = events[self._next_event] if self._next_event < len(events) else math.inf
            if at <= self._done_ms:
                self._next_event += 1
                continue
            change = min((c for next_change in changes if (c := next_change()) is not None),
                         default=None)
            if change is not None and change <= t_ms and change < at:
                if self._advance_to(change - BEFORE_MS):  # applied as a set at its time
                    self._change(change)
                continue
            if at > t_ms:
                if self._advance_to(t_ms):
                    return
                continue
            if not self._advance_to(at - BEFORE_MS if at in self._early else at):
                continue
            self._next_event += 1
            self._call("at_time", at)
            if at in self._by_time:
                self._run_steps(at)
            self._done_ms = at
            if self.fail_fast and self.result.failures:
                return

    def finish(self) -> SimResult:
        result = self.result
        result.end_ms = self.end_ms
        result.final = self._final_state()
        self._call("finish", result)
        return result

    def _change(self, at: float) -> None:
        """An observer's change comes at ``at`` (a reader may want the state as of now)."""
        for hook in self._changed:
            hook(at)

    def _advance_to(self, t_ms: float) -> bool:
        """Let master time pass up to ``t_ms``; False when an observer paused the board
        before it (``wake_at``). With a ``progress``, in slices of ``PROGRESS_MS``, each
        reported (the board ends a slice exactly where one long advance would pass: the
        same cycles run)."""
        self._limit = t_ms
        progress = self._progress
        while (delta_us := round(t_ms * 1000) - round(self.now_ms() * 1000)) > 0:
            self._paused = False
            step_us = min(delta_us, round(PROGRESS_MS * 1000)) if progress else delta_us
            self.board.advance(step_us / 1000)  # whole microseconds, as the board counts
            if self._paused:
                return round(t_ms * 1000) <= round(self.now_ms() * 1000)
            if progress is not None and step_us < delta_us:
                progress(self.now_ms(), self.end_ms)
        return True

    def _apply(self, step: Step) -> None:
        bus = self.board.bus
        for address in step.remove_slaves:
            for slave in list(bus.at(address)):
                bus.remove(slave)
        for spec in step.add_slaves:
            bus.attach(_slave(spec))
        if step.power_fail is True:
            bus.power_fail()
        elif step.power_fail is False:
            bus.power_restore()
        if step.press_set_button:
            self.board.press_set_button()
        for operand, value, line in step.set:
            self.set(operand, value, step=step, line=line)
        for operand, _, line in step.expect:
            self._need_output(operand, step, line)

    def _need_output(self, operand: Operand, step: Step, line: int) -> None:
        """An expectation of a slave's outputs needs the slave: one never on the bus reads
        0, so a typo in its address would pass whatever the program does. (A slave the
        scenario removes stays one it may expect of: its outputs are 0 by then.)"""
        node = operand.node
        if node.kind not in (ast.OperandKind.Q, ast.OperandKind.QB):
            return
        addresses = (node.address, node.address + 1) if node.kind is ast.OperandKind.QB \
            else (node.address,)
        named = {spec.address for s in self.scenario.steps for spec in s.add_slaves}
        named.update(a for s in self.scenario.steps for a in s.remove_slaves)
        if not any(a in named or self.board.bus.at(a) for a in addresses):
            self._need_slave(node.address, step, line, str(operand), "expects")

    def _observe(self) -> None:
        """Called by the board after each AS-i cycle that ran: time 0, stops, and the
        observers' ``after_cycle``."""
        board = self.board
        running = board.running
        for watch in self._after_any_cycle:
            watch()
        if self._t0 is None:
            if not running:
                return
            self._t0 = board.now_ms
            first_tick = self.scenario.first_tick_ms
            if first_tick is not None:  # the clock's phase the scenario was written for
                board.move_next_tick(board.now_us + round(first_tick * 1000))
        if running != self.running:
            self.running = running
            if not running:
                self._call("stopped", self.now_ms())
        after_cycle = self._after_cycle
        if after_cycle:
            now = self.now_ms()
            for observe in after_cycle:
                observe(now)
