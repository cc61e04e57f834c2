"""Running a scenario: a program on a fresh emulated master, in virtual time.

The program's image (built by ``asictl.build`` from source, an uploaded [RAW] file or a
.hex image) is downloaded through the same driver and commands as
``asictl download`` (so the simulation exercises what the plant would get), then the
scenario's steps are applied at their times. Master time 0 is the moment the download
has set the start flag. Timing rules (docs/simulation.md): a ``set`` at T takes effect for
every program cycle that starts at or after T; an ``expect`` at T checks the state left
by the cycles that ran before T; at equal times sets come before checks.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from asictl.board.asi import AsiBus, Slave
from asictl.board.board import Pc2Board
from asictl.build import Build
from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity, Span
from asictl.host.driver import EmulatedPort, Pc2Driver
from asictl.host.transfer import Pc2Transport, StartMode, download
from asictl.il import ast
from asictl.il.loader import Program
from asictl.image import ProgramImage
from asictl.platform import pc2 as d
from asictl.runtime.program_map import CellKind, ProgramMap
from asictl.sim.operands import Operand, parse_operand
from asictl.sim.scenario import Scenario, SlaveSpec, Step
from asictl.sim.trace import Signal, Trace

#: Sets happen this long before their time, so that no cycle at exactly T has run yet.
_BEFORE_US = 0.001
#: How long the master may take after the download to start the program.
_START_WAIT_MS = 1000.0


@dataclass
class Failure:
    step: Step
    line: int
    operand: Operand
    expected: int
    got: int

    def __str__(self) -> str:
        return f"at {self.step.at_ms:g} ms: {self.operand} expected {self.expected}, got {self.got}"


@dataclass
class Stop:
    at_ms: float
    reason: str


@dataclass
class SimResult:
    scenario: Scenario
    checked: int = 0
    failures: list[Failure] = field(default_factory=list)
    stops: list[Stop] = field(default_factory=list)
    trace: Trace | None = None
    end_ms: float = 0.0
    cycles: int = 0

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


class Simulation:
    """One scenario on one fresh master, running the image of one build."""

    def __init__(
        self,
        build: Build,
        scenario: Scenario,
        *,
        duration_ms: float | None = None,
        trace: bool = False,
    ) -> None:
        if build.image is None:
            raise ValueError("a simulation needs a build with an image")
        self.build = build
        self.image = build.image
        self.scenario = scenario
        self.end_ms = duration_ms if duration_ms is not None else scenario.end_ms
        specs = scenario.slaves if scenario.slaves is not None else _setup_slaves(self.image)
        self.board = Pc2Board(bus=AsiBus([_slave(s) for s in specs]))
        if scenario.cycle_ms is not None:
            self.board.cycle_period_us = round(scenario.cycle_ms * 1000)
        self.result = SimResult(scenario)
        #: what a trace cannot show, in words (an image without its source)
        self.untraced = ""
        self._signals: list[tuple[Signal, Callable[[Simulation], int]]] = []
        if trace:
            program = build.source_program()
            if program is not None:
                self._signals = _trace_signals(program)
            else:
                self._signals = _image_signals(self.image)
                self.untraced = (
                    "the image carries no source: the trace shows the operands its program "
                    "map names (inputs and outputs of its slaves, the flag bytes it keeps "
                    "in internal RAM, its timers), not the flags it keeps in the "
                    "communication memory"
                )
        self._t0: float | None = 0.0
        self._running = True

    # ------------------------------------------------------------------ reading

    def now_ms(self) -> float:
        return self.board.now_ms - (self._t0 or 0.0)

    def read(self, operand: Operand) -> int:
        """An operand's value now: inputs as the slaves deliver them, outputs as the slaves
        receive them (0 while the program is stopped), flags from the communication memory,
        the rest from the program's memory."""
        board = self.board
        node = operand.node
        match node:
            case ast.ImageBit(area=ast.BitArea.I, address=a, bit=b):
                return self._slave_inputs(a) >> b & 1
            case ast.ImageByte(area=ast.ByteArea.IB, number=n):
                return self._slave_inputs(n) | self._slave_inputs(n + 1) << 4
            case ast.ImageBit(area=ast.BitArea.Q, address=a, bit=b):
                return board.outputs[a >> 1] >> ((a & 1) * 4 + b) & 1
            case ast.ImageByte(area=ast.ByteArea.QB, number=n):
                return board.outputs[n >> 1]
            case ast.ImageBit(area=ast.BitArea.F, address=a, bit=b):
                return board.dpram[d.FLAGS + a] >> b & 1
            case ast.ImageByte(area=ast.ByteArea.FY, number=n):
                return board.dpram[d.FLAGS + n]
        runner = board.program
        if runner is None:
            return 0
        pmap = runner.pmap
        match node:
            case ast.ImageBit(area=ast.BitArea.I2, address=a, bit=b):
                cell = pmap.cells.get((CellKind.I2, a >> 1))
                value = runner.read(cell) if cell else 0
                return value >> ((a & 1) * 4 + b) & 1
            case ast.ImageByte(area=ast.ByteArea.I2B, number=n):
                cell = pmap.cells.get((CellKind.I2, n >> 1))
                return runner.read(cell) if cell else 0
            case ast.TimerRef(number=n):
                address = pmap.timers.get(n)
                return int(address is not None and self._word(runner, address) != 0)
            case ast.CounterRef(number=n):
                address = pmap.counters.get(n)
                return int(address is not None and self._word(runner, address) & 0xFFF != 0)
            case ast.ImageByte(area=ast.ByteArea.PSEG, number=n):
                return runner.cpu.xdata.read(pmap.pseg + n)
            case ast.VarBit(name=name, offset=o, bit=b):
                return runner.cpu.xdata.read(pmap.variables[name.casefold()].address + o) >> b & 1
            case ast.VarByte(name=name, offset=o):
                return runner.cpu.xdata.read(pmap.variables[name.casefold()].address + o)
        raise AssertionError(node)

    def _slave_inputs(self, address: int) -> int:
        slaves = self.board.bus.at(address)
        return slaves[0].inputs if slaves else 0

    @staticmethod
    def _word(runner, address: int) -> int:
        return runner.cpu.xdata.read(address) | runner.cpu.xdata.read(address + 1) << 8

    # ------------------------------------------------------------------ writing

    def _set(self, step: Step, operand: Operand, value: int, line: int) -> None:
        node = operand.node
        match node:
            case ast.ImageBit(area=ast.BitArea.I, address=a, bit=b):
                slave = self._need_slave(a, step, line, str(operand))
                slave.inputs = slave.inputs & ~(1 << b) | value << b
            case ast.ImageByte(area=ast.ByteArea.IB, number=n):
                for address, nibble in ((n, value & 0xF), (n + 1, value >> 4)):
                    if nibble or self.board.bus.at(address):
                        self._need_slave(address, step, line, str(operand)).inputs = nibble
            case ast.ImageBit(area=ast.BitArea.F, address=a, bit=b):
                old = self.board.dpram[d.FLAGS + a]
                self._host_write(d.FLAGS + a, old & ~(1 << b) | value << b)
            case ast.ImageByte(area=ast.ByteArea.FY, number=n):
                self._host_write(d.FLAGS + n, value)

    def _need_slave(self, address: int, step: Step, line: int, what: str) -> Slave:
        slaves = self.board.bus.at(address)
        if not slaves:
            raise DiagnosticError([Diagnostic(
                Severity.ERROR, ScenarioCode.NO_SUCH_SLAVE,
                f"at {step.at_ms:g} ms: '{what}' sets slave {address}, which is not on the bus",
                Span(self.scenario.file, line, 1),
            )])
        return slaves[0]

    def _host_write(self, address: int, value: int) -> None:
        """As a host writes the communication memory: through the board's I/O registers."""
        board = self.board
        board.io_write(2, address >> 8)
        board.io_write(1, address & 0xFF)
        board.io_write(0, value)

    # ------------------------------------------------------------------ running

    def start(self) -> None:
        """Download the program as ``asictl download --start`` does; time 0 is the master
        time of the first program cycle (or, if the program cannot start, one second after
        the download, the stop then being reported at time 0)."""
        board = self.board
        board.advance(100)  # power-up: the master finds its slaves
        download(Pc2Transport(Pc2Driver(EmulatedPort(board))), self.image, start=StartMode.START)
        self._t0 = None
        board.observer = self._observe  # notes the first program cycle as time 0
        deadline = board.now_ms + _START_WAIT_MS
        while self._t0 is None and board.now_ms < deadline:
            board.advance(0.1)
        if self._t0 is None:
            self._t0 = board.now_ms
            self._running = False
            self.result.stops.append(Stop(0.0, board.stop_message or board.stop_reason.name))

    def run(self) -> SimResult:
        self.start()
        by_time: dict[float, list[Step]] = {}
        for step in self.scenario.ordered():
            by_time.setdefault(step.at_ms, []).append(step)
        for at in sorted(by_time):
            if at > self.end_ms:
                break
            self._advance_to(at - _BEFORE_US)
            for step in by_time[at]:
                self._apply(step)
            for step in by_time[at]:
                self._check(step)
        self._advance_to(self.end_ms)
        self.result.end_ms = self.end_ms
        if self._signals:
            self.result.trace = Trace([s for s, _ in self._signals], end_ms=self.end_ms)
        return self.result

    def _advance_to(self, t_ms: float) -> None:
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
            self._set(step, operand, value, line)

    def _check(self, step: Step) -> None:
        for operand, expected, line in step.expect:
            self.result.checked += 1
            got = self.read(operand)
            if got != expected:
                self.result.failures.append(Failure(step, line, operand, expected, got))

    def _observe(self) -> None:
        """Called by the board after each AS-i cycle that ran: stops and trace samples."""
        board = self.board
        running = board.control_state is d.ControlState.RUNNING
        if self._t0 is None:
            if not running:
                return
            self._t0 = board.now_ms
        now = self.now_ms()
        if running != self._running:
            self._running = running
            if not running:
                self.result.stops.append(Stop(now, board.stop_message or board.stop_reason.name))
        for signal, read in self._signals:
            signal.record(now, read(self))


def _trace_signals(program: Program) -> list[tuple[Signal, Callable[[Simulation], int]]]:
    """Every I and Q bit the program uses, the flags it writes, its timers' status."""

    inputs, outputs, flags, timers = set(), set(), set(), set()
    for module in program.modules():
        for section in module.sections:
            items: list[tuple[object, bool]] = []
            if isinstance(section, ast.ProgramSection):
                for s in section.statements:
                    if isinstance(s, ast.Param):  # PARAM answers in flag byte 127
                        flags.add("FY 127")
                    operand = getattr(s, "operand", None)
                    writes = isinstance(s, ast.Store | ast.Transfer)
                    items.append((operand, writes))
            elif isinstance(section, ast.GatingSection):
                for line in section.lines:
                    items.append((line.target, True))
                    items.extend((t.operand, False) for t in line.terms)
            for operand, writes in items:
                match operand:
                    case ast.ImageBit(area=ast.BitArea.I | ast.BitArea.I2, address=a, bit=b):
                        inputs.add((a, b))
                    case ast.ImageBit(area=ast.BitArea.Q, address=a, bit=b):
                        outputs.add((a, b))
                    case ast.ImageBit(area=ast.BitArea.F, address=a, bit=b) if writes:
                        flags.add(f"F {a}.{b}")
                    case ast.ImageByte(area=ast.ByteArea.FY, number=n) if writes:
                        flags.add(f"FY {n}")
                    case ast.TimerRef(number=n):
                        timers.add(n)
    names = (
        [f"I {a}.{b}" for a, b in sorted(inputs)]
        + [f"Q {a}.{b}" for a, b in sorted(outputs)]
        + sorted(flags, key=_flag_order)
        + [f"T {n}" for n in sorted(timers)]
    )
    return _signals(names)


def _image_signals(image: ProgramImage) -> list[tuple[Signal, Callable[[Simulation], int]]]:
    """What an image's program map names: the I/O bits of the projected slaves its cells
    hold, the flag bytes in cells, the timers."""
    pmap = image.pmap
    projected = set(image.configuration.projected())

    def bits(kinds: tuple[CellKind, ...]) -> list[tuple[int, int]]:
        slaves = {
            address
            for (kind, k), _ in pmap.cells.items() if kind in kinds
            for address in (2 * k, 2 * k + 1) if address in projected
        }
        return [(a, b) for a in sorted(slaves) for b in range(4)]

    names = (
        [f"I {a}.{b}" for a, b in bits((CellKind.I, CellKind.I2))]
        + [f"Q {a}.{b}" for a, b in bits((CellKind.Q,))]
        + [f"FY {n}" for kind, n in sorted(pmap.cells) if kind is CellKind.F]
        + [f"T {n}" for n in sorted(pmap.timers)]
    )
    return _signals(names)


def _signals(names: list[str]) -> list[tuple[Signal, Callable[[Simulation], int]]]:
    signals = []
    for name in names:
        operand = parse_operand(name)
        width = 1 if operand.is_bit else 8
        signals.append((Signal(name, width), lambda sim, op=operand: sim.read(op)))
    return signals


def _flag_order(name: str) -> tuple[bool, list[int]]:
    return name.startswith("FY"), [int(x) for x in name.split()[1].split(".")]
