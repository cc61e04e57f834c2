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
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import PurePath

from asictl.board.asi import AsiBus, Slave
from asictl.board.board import Pc2Board
from asictl.build import Build
from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity, Span
from asictl.host.driver import EmulatedPort, Pc2Driver
from asictl.host.transfer import Pc2Transport, StartMode, download
from asictl.il import ast
from asictl.il.loader import Program
from asictl.image.eeprom import ProgramImage
from asictl.observe.iltrace import LineRow
from asictl.observe.operands import Operand
from asictl.observe.symbols import SymbolTable
from asictl.observe.view import ProgramView, host_write, read_on_board
from asictl.platform import pc2 as d
from asictl.platform.master import IO_CODE_BITS, ControlFlag
from asictl.runtime.line_map import LineMap
from asictl.runtime.program_map import ProgramMap
from asictl.runtime.runner import ProgramRunner
from asictl.sim.observation import Observation, Refusal, Stop
from asictl.sim.scenario import Scenario, SlaveSpec, Step
from asictl.sim.trace import Mark, Signal, Trace
from asictl.sim.tracing import RUNNING, LineTrace, Sample, Signals

#: Sets happen this long before their time, so that no cycle at exactly T has run yet.
_BEFORE_MS = 0.001
#: The master's power-up: it finds its slaves before the host downloads.
_POWER_UP_MS = 100.0
#: How long the master may take after the start command to run the first cycle.
_START_WAIT_MS = 1000.0
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

    @property
    def at_ms(self) -> float:
        return self.step.at_ms

    def __str__(self) -> str:
        name = self.written or str(self.operand)
        return f"at {self.step.at_ms:g} ms: {name} expected {self.expected}, got {self.got}"


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
        progress: Callable[[float, float], None] | None = None,
    ) -> None:
        """``progress(now_ms, end_ms)`` hears, every ``PROGRESS_MS`` of master time, how
        far the run is (a long simulation's progress line)."""
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
        self._signals: list[tuple[Signal, Sample]] = []
        if trace:
            traced = Signals(self.program, self.image, self.symbols, signals, self.read,
                             lambda: int(self._running))
            self._signals, self.untraced = traced.sampled, traced.untraced
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
        #: step times and trace window edges, in order; the next one to come
        self._events = sorted({*self._by_time, *marks})
        self._next_event = 0
        self._progress = progress
        self._done_ms = -1.0

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
        self._t0 = None

    def begin(self) -> None:
        """Apply the steps at time 0 (and check its expectations against the state before
        any cycle), then set the start flag: time 0 is the master time of the first
        program cycle (or, if the program cannot start within a second, the moment the
        start was given, the stop then being reported at time 0)."""
        board = self.board
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
        edges) on the way; the steps at ``t_ms`` are applied and its cycles run."""
        events = self._events
        while self._next_event < len(events) and events[self._next_event] <= t_ms:
            at = events[self._next_event]
            self._next_event += 1
            if at <= self._done_ms:
                continue
            step = at in self._by_time
            self._advance_to(at - _BEFORE_MS if step else at)
            self._window_edge(at)
            if step:
                self._run_steps(at)
            self._done_ms = at
        self._advance_to(t_ms)

    def finish(self) -> SimResult:
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
        return result

    def _window_edge(self, at: float) -> None:
        if self._tracer is None:
            return
        start, end = self.window
        if at == start:
            self._trace_lines(True)
        if end is not None and at == end + _BEFORE_MS:
            self._trace_lines(False)

    def _advance_to(self, t_ms: float) -> None:
        progress = self._progress
        if progress is not None:  # in slices, each reported (the board ends a slice
            # exactly where one long advance would pass: the same cycles run)
            while t_ms - self.now_ms() > PROGRESS_MS:
                self.board.advance(PROGRESS_MS)
                progress(self.now_ms(), self.end_ms)
        delta = t_ms - self.now_ms()
        if delta > 0:
            self.board.advance(delta)

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
        if self._t0 is None:
            if not running:
                return
            self._t0 = board.now_ms
        if running != self._running:
            self._running = running
            if not running:
                self.observation.stop(self.now_ms())
        if self._signals:
            now = self.now_ms()
            for signal, read in self._signals:
                signal.record(now, read())

    def _trace_lines(self, on: bool) -> None:
        if self._tracer is not None:
            self._tracer.switch(on, self.view)

