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

Closed loop: the scenario's plant models (sim/plant.py) are evaluated after every AS-i
cycle that ran and at each model's own next change, which is applied as a ``set`` at
its time; a model that will change an input sooner than the current ``advance`` was
planned to end pauses the board (``Pc2Board.pause``) there. A step with ``within_ms``
has its expectations decided when its window closes: each holds if its value was seen
at the window's edges or after any AS-i cycle that ran in it.
"""

from __future__ import annotations

import copy
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import PurePath

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
from asictl.mcs51.emulator import Emulator
from asictl.observe.coverage import Collector, Coverage
from asictl.observe.iltrace import LineRow
from asictl.observe.operands import Operand
from asictl.observe.symbols import SymbolTable
from asictl.observe.view import ProgramView, host_write, read_on_board
from asictl.platform import pc2 as d
from asictl.platform.master import IO_CODE_BITS, ControlFlag
from asictl.runtime.line_map import LineMap, SourceLine
from asictl.runtime.program_map import ProgramMap
from asictl.runtime.runner import ProgramRunner
from asictl.sim.observation import Observation, Refusal, Stop
from asictl.sim.plant import Model, Plant
from asictl.sim.scenario import Scenario, SlaveSpec, Step
from asictl.sim.trace import Mark, Signal, Trace
from asictl.sim.tracing import RUNNING, LineTrace, Sample, Signals

#: Sets happen this long before their time, so that no cycle at exactly T has run yet.
_BEFORE_MS = 0.001
#: The master's power-up: it finds its slaves before the host downloads.
_POWER_UP_MS = 100.0
#: How long the master may take after the start command to run the first cycle.
_START_WAIT_MS = 1000.0
#: How often a trace samples a moving plant model without a cycle period of its own.
_SAMPLE_MS = 10.0
#: How much master time passes between two reports to a simulation's ``progress``.
PROGRESS_MS = 1000.0


@dataclass
class Failure:
    step: Step
    line: int
    operand: Operand
    expected: int
    got: int
    #: the operand as the scenario wrote it (a symbol, say)
    written: str = ""
    #: the IL line that last wrote the operand before the step's time (``prog.asi:12``),
    #: where it is known: for the expectations of a step with a tolerance window
    writer: str = ""

    @property
    def at_ms(self) -> float:
        return self.step.at_ms

    def __str__(self) -> str:
        name = self.written or str(self.operand)
        window = f" (within {self.step.within_ms:g} ms)" if self.step.within_ms else ""
        text = f"at {self.step.at_ms:g} ms{window}: {name} expected {self.expected}, got {self.got}"
        return f"{text}; last written by {self.writer}" if self.writer else text


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


@dataclass(frozen=True)
class FinalState:
    """What a program left when the simulation ended: what ``sim`` without expectations
    shows, so that a quick run answers "what does it do?" without a scenario."""

    at_ms: float
    #: each slave with output bits on the bus: the four bits it receives (D0 = bit 0)
    outputs: dict[int, int]
    #: each counter of the program: its value
    counters: dict[int, int]
    #: each timer of the program: its remaining time in milliseconds
    timers_ms: dict[int, int]

    def as_json(self) -> dict[str, object]:
        return {
            "at_ms": self.at_ms,
            "outputs": {str(a): v for a, v in self.outputs.items()},
            "counters": {str(n): v for n, v in self.counters.items()},
            "timers_ms": {str(n): v for n, v in self.timers_ms.items()},
        }


@dataclass
class SimResult:
    scenario: Scenario
    checked: int = 0
    failures: list[Failure] = field(default_factory=list)
    stops: list[Stop] = field(default_factory=list)
    refusals: list[Refusal] = field(default_factory=list)
    trace: Trace | None = None
    il_rows: list[LineRow] = field(default_factory=list)
    end_ms: float = 0.0
    final: FinalState | None = None
    #: what the run reached of the program (with ``coverage=True``)
    coverage: Coverage | None = None

    @property
    def passed(self) -> bool:
        return not self.failures


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
        ``progress(now_ms, end_ms)`` hears, every ``PROGRESS_MS`` of master time, how far
        the run is (a long simulation's progress line)."""
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
        self.window = window
        #: what a trace cannot show, in words (an image without its source)
        self.untraced = ""
        #: the scenario's plant models (copies: a scenario may run more than once)
        self.plant = Plant(copy.deepcopy(scenario.plants))
        self._io = _PlantIO(self)
        #: where the current ``advance`` ends, and whether a model paused it before
        self._limit = math.inf
        self._paused = False
        self._signals: list[tuple[Signal, Sample]] = []
        #: the operands the trace samples after every cycle that runs
        self._traced: list[Operand] = []
        self._trace = trace
        #: how often a trace samples a moving model between its changes
        self._sample_ms = (scenario.cycle_ms or _SAMPLE_MS) if trace else None
        if trace:
            lanes = [(Signal(lane.name, lane.width, operand=lane.name), lane.sample)
                     for lane in self.plant.lanes()]
            traced = Signals(self.program, self.image, self.symbols, signals, self.read,
                             lambda: int(self._running), lanes,
                             [str(o) for m in self.plant.models for o in m.driven()])
            self._signals, self.untraced = traced.sampled, traced.untraced
            self._traced = traced.operands
        #: collects the IL coverage (observe/coverage.py) once the program is loaded
        self.coverage = coverage
        #: exact hit counts (every cycle run, none skipped as a repeat of the last)
        self.coverage_counts = coverage_counts
        #: end the run at the first failed expectation (what mutation testing needs)
        self.fail_fast = fail_fast
        self._collectors: list[Collector] = []
        self._tracer: LineTrace | None = None
        if il_trace:
            self._tracer = LineTrace(self.board, source_texts(build), self.program,
                                     self.line_map, window, self._since_start)
        self._t0: float | None = 0.0
        self._running = True
        self.observation = Observation(
            self.board, self.line_map, self._since_start, self.result.stops
        )
        self._by_time: dict[float, list[Step]] = {}
        for step in scenario.ordered():
            if step.at_ms <= self.end_ms:
                self._by_time.setdefault(step.at_ms, []).append(step)
        start, end = window  # the trace goes on at its start, off after the cycles at its end
        marks = {t for t in (start, None if end is None else end + _BEFORE_MS)
                 if t is not None and 0 < t <= self.end_ms}
        self._marks = marks
        #: the tolerance windows by the times they open and close; those open now
        self._opens: dict[float, list[Step]] = {}
        self._closes: dict[float, list[Step]] = {}
        for steps in self._by_time.values():
            for step in steps:
                if step.within_ms and step.expect:
                    self._opens.setdefault(max(0.0, step.at_ms - step.within_ms), []).append(step)
                    self._closes.setdefault(step.at_ms + step.within_ms, []).append(step)
        self._windows: dict[int, _Window] = {}
        self._writers = _Writers(self) if track_writers else None
        #: step times, window edges and trace window edges, in order; the next one to come
        self._events = sorted({*self._by_time, *marks, *self._opens, *self._closes})
        self._next_event = 0
        self._progress = progress
        self._done_ms = -1.0
        self._tick_exactly()

    def _tick_exactly(self) -> None:
        """The timers whose remaining time is sampled after every cycle that runs (by the
        trace, a tolerance window, a plant model) tick one by one on the board: a step
        over the ticks of an unread timer would hide the values between."""
        sampled = [*self._traced, *(o for m in self.plant.models for o in m.sensed()),
                   *(o for steps in self._opens.values() for s in steps for o, _, _ in s.expect)]
        self.board.tick_exactly({o.node.address for o in sampled
                                 if o.node.kind is ast.OperandKind.T
                                 and o.node.width is not ast.Width.BIT})

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
        """An operand's value now: inputs as the slaves deliver them, outputs as the slaves
        receive them (0 while the program is stopped), flags from the communication memory,
        the rest from the program's memory."""
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
        self.plant.add(model)
        try:
            self._check_plant([model])
        except ValueError:
            self.plant.models.remove(model)
            raise
        if self._trace:
            known = {signal.operand for signal, _ in self._signals}
            for operand in model.driven():
                if str(operand) not in known:
                    name = self.symbols.label(str(operand))
                    self._signals.append((Signal(name, operand.width, operand=str(operand)),
                                          functools.partial(self.read, operand)))
            self._signals += [(Signal(lane.name, lane.width, operand=lane.name), lane.sample)
                              for lane in model.lanes()]
        self._tick_exactly()
        return model

    def evaluate_plant(self) -> None:
        """Evaluate the plant models now, so that their state is as of now for a reader
        (between their changes they are evaluated only after the cycles that ran)."""
        if self.plant.models and self.started:
            self._plant_update(self.now_ms())

    def trace_now(self) -> Trace:
        """The trace recorded so far (empty without ``trace=True``), with the stops."""
        marks = [Mark(s.at_ms, f"stopped: {s.text}", RUNNING) for s in self.result.stops]
        return Trace([s for s, _ in self._signals], end_ms=self._since_start(), marks=marks)

    def _check_plant(self, models: list[Model]) -> None:
        """Every input these plant models drive belongs to a slave on the bus."""
        for model in models:
            for operand in model.driven():
                node = operand.node
                if node.kind in (ast.OperandKind.I, ast.OperandKind.IB) \
                        and not self.board.bus.at(node.address):
                    message = (f"{model.name} drives '{operand}' of slave {node.address}, "
                               "which is not on the bus")
                    if not model.line:
                        raise ValueError(message)
                    raise DiagnosticError([Diagnostic(
                        Severity.ERROR, ScenarioCode.NO_SUCH_SLAVE, message,
                        Span(self.scenario.file, model.line, 1),
                    )])

    def _need_slave(self, address: int, step: Step | None, line: int, what: str) -> Slave:
        slaves = self.board.bus.at(address)
        if not slaves:
            when = f"at {step.at_ms:g} ms: " if step is not None else ""
            message = f"{when}'{what}' sets slave {address}, which is not on the bus"
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
        self.observation.watch_firmware()
        if self._writers is not None:
            self._writers.install()
        self._watch_coverage()
        self._t0 = None

    def _watch_coverage(self) -> None:
        """Collect coverage from the runner now loaded (a reload makes a new one)."""
        runner = self.board.program
        if not self.coverage or self.program is None or runner is None:
            return
        if self._collectors and self._collectors[-1].runner is runner:
            return
        collector = Collector(runner, self.line_map, self.program,
                              counts=self.coverage_counts)
        collector.attach()
        self._collectors.append(collector)

    def begin(self) -> None:
        """Apply the steps at time 0 (and check its expectations against the state before
        any cycle), then set the start flag: time 0 is the master time of the first
        program cycle (or, if the program cannot start within a second, the moment the
        start was given, the stop then being reported at time 0)."""
        board = self.board
        if self.plant.models:  # the models' inputs at time 0, before any cycle
            self._check_plant(self.plant.models)
            self.plant.update(0.0, self._io)
        self._open_windows(0.0)
        self._run_steps(0.0)
        if self._tracer is not None and self.window[0] <= 0:
            self._trace_lines(True)
        board.observer = self._observe  # notes the first program cycle as time 0
        flags = int(board.control_flags) & ~(ControlFlag.CONTROL_ACTIVE | ControlFlag.RESET)
        self._host_write(d.CONTROL_FLAGS, flags | ControlFlag.START)
        self._host_write(d.COMMAND, d.Command.WRITE_CONTROL_FLAGS)
        deadline = board.now_ms + _START_WAIT_MS + 2 * (self.scenario.cycle_ms or 0.0)
        while self._t0 is None and board.now_ms < deadline:
            board.advance(_BEFORE_MS)  # to the microsecond: time 0 is exact
        if self._t0 is None:
            self._t0 = board.now_ms
            self._running = False
            self.observation.stop(0.0)
        end = self.window[1]
        if end is not None and end <= 0:  # a window of time 0 alone: its cycle has run
            self._trace_lines(False)

    @property
    def started(self) -> bool:
        return self._t0 is not None

    def _run_steps(self, at: float) -> None:
        """The steps at one time: all sets (and bus changes) first, then all checks."""
        steps = self._by_time.get(at, [])
        for step in steps:
            self._apply(step)
        for step in steps:
            self._check(step)
        self._done_ms = max(self._done_ms, at)

    def run(self) -> SimResult:
        self.start()
        self.run_to(self.end_ms)
        self._trace_lines(False)
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
        """Let master time pass up to ``t_ms``, applying the steps (and trace window
        edges) and evaluating the plant models at their changes on the way; the steps at
        ``t_ms`` are applied and its cycles run."""
        events = self._events
        while True:
            at = events[self._next_event] if self._next_event < len(events) else math.inf
            if at <= self._done_ms:
                self._next_event += 1
                continue
            change = self.plant.next_change_ms(self._sample_ms) if self.plant.models else None
            if change is not None and change <= t_ms and change < at:
                if self._advance_to(change - _BEFORE_MS):  # applied as a set at its time
                    self._plant_update(change)
                continue
            if at > t_ms:
                if self._advance_to(t_ms):
                    return
                continue
            step = at in self._by_time
            edge = step or at in self._opens or at in self._closes
            if not self._advance_to(at - _BEFORE_MS if edge else at):
                continue
            self._next_event += 1
            self._close_windows(at)
            self._open_windows(at)
            self._window_edge(at)
            if step:
                self._run_steps(at)
            self._done_ms = at
            if self.fail_fast and self.result.failures:
                return

    def _open_windows(self, at: float) -> None:
        for step in self._opens.get(at, []):
            window = _Window(step, step.at_ms + step.within_ms)
            window.sample(self.read)
            self._windows[id(step)] = window

    def _close_windows(self, at: float | None) -> None:
        """Decide the windows closing at ``at`` (None: all still open, at the end)."""
        for key, window in list(self._windows.items()):
            if at is not None and window.closes_at != at:
                continue
            del self._windows[key]
            window.sample(self.read)
            step = window.step
            for index, (operand, expected, line) in enumerate(step.expect):
                self.result.checked += 1
                if index not in window.held:
                    self.result.failures.append(Failure(
                        step, line, operand, expected, window.got.get(index, 0),
                        step.written.get((line, str(operand)), ""),
                        window.writers.get(index, ""),
                    ))

    def finish(self) -> SimResult:
        self._close_windows(None)
        result = self.result
        result.end_ms = self.end_ms
        result.final = self._final_state()
        result.refusals = self.observation.refusals()
        if self._signals:
            marks = [Mark(f.at_ms, f"{f.written or f.operand} expected {f.expected}, got {f.got}",
                          str(f.operand)) for f in result.failures]
            marks += [Mark(s.at_ms, f"stopped: {s.text}", RUNNING) for s in result.stops]
            result.trace = Trace([s for s, _ in self._signals], end_ms=self.end_ms,
                                 marks=sorted(marks, key=lambda m: m.at_ms))
        if self._tracer is not None:
            result.il_rows = self._tracer.rows
        if self.coverage and self.program is not None:
            result.coverage = Coverage()
            for collector in self._collectors:
                result.coverage.merge(collector.coverage())
        return result

    def _window_edge(self, at: float) -> None:
        if self._tracer is None:
            return
        start, end = self.window
        if at == start:
            self._trace_lines(True)
        if end is not None and at == end + _BEFORE_MS:
            self._trace_lines(False)

    def _advance_to(self, t_ms: float) -> bool:
        """Let master time pass up to ``t_ms``; False when a plant model paused the board
        before it (its next change came sooner than planned). With a ``progress``, in
        slices of ``PROGRESS_MS``, each reported (the board ends a slice exactly where one
        long advance would pass: the same cycles run)."""
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

    def _plant_update(self, at: float) -> None:
        """Evaluate the plant models at ``at`` (an input of theirs changes then)."""
        self.plant.update(at, self._io)
        self._sample(at)

    def _sample(self, now: float) -> None:
        for signal, read in self._signals:
            signal.record(now, read())

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

    def _check(self, step: Step) -> None:
        window = self._windows.get(id(step))
        if window is not None:  # decided when the window closes
            window.sample(self.read)
            for index, (operand, _, _) in enumerate(step.expect):
                window.got[index] = self.read(operand)
                if self._writers is not None:
                    window.writers[index] = self._writers.last(operand)
            return
        written = step.written
        for operand, expected, line in step.expect:
            self.result.checked += 1
            got = self.read(operand)
            if got != expected:
                self.result.failures.append(Failure(
                    step, line, operand, expected, got, written.get((line, str(operand)), "")
                ))

    def _observe(self) -> None:
        """Called by the board after each AS-i cycle that ran: stops and trace samples."""
        board = self.board
        running = board.control_state is d.ControlState.RUNNING
        if self.coverage and (not self._collectors
                              or self._collectors[-1].runner is not board.program):
            self._watch_coverage()
        if self._t0 is None:
            if not running:
                return
            self._t0 = board.now_ms
        if running != self._running:
            self._running = running
            if not running:
                self.observation.stop(self.now_ms())
        if self.plant.models:
            self.plant.update(self.now_ms(), self._io)
            change = self.plant.next_change_ms(self._sample_ms)
            if change is not None and change - _BEFORE_MS < self._limit:
                self._paused = True  # a model changes an input before the planned end
                board.pause()
        for window in self._windows.values():
            window.sample(self.read)
        if self._signals:
            self._sample(self.now_ms())

    def _trace_lines(self, on: bool) -> None:
        if self._tracer is not None:
            self._tracer.switch(on, self.view)



class _PlantIO:
    """The plant models' view of a simulation: operands as ``Simulation.read`` gives
    them, inputs written as a scenario's ``set`` writes them."""

    def __init__(self, simulation: Simulation) -> None:
        self._simulation = simulation

    def read(self, operand: Operand) -> int:
        return self._simulation.read(operand)

    def write(self, operand: Operand, value: int) -> None:
        self._simulation.set(operand, value)


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

    def __init__(self, simulation: Simulation) -> None:
        self.simulation = simulation
        self.expected = [operand for steps in simulation._by_time.values() for step in steps
                         if step.within_ms for operand, _, _ in step.expect]
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
