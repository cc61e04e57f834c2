"""A Python test API for programs: the emulated master in virtual time, driven from code.

``Plc.load("prog.asi", cycle_ms=5)`` builds the program and downloads it to a fresh
emulated master, as ``asictl sim`` does; the test then sets inputs, lets time pass, reads
operands and checks them, and may couple plant models written in Python
(``on_cycle``) or the scenario's own (``add_plant``), so that a sequence is tested
closed loop the way cocotb drives a hardware simulation. docs/testing.md is the
contract; the names here are stable.

Time is the scenario's (docs/simulation.md): time 0 is the first program cycle, which
runs when time first passes (``run``, ``run_until``), so what is set before that is seen
by the first cycle. Failures read like a scenario's: ``test_seq.py:14: at 250 ms: Q 2.0
expected 1, got 0``.
"""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from types import TracebackType
from typing import Any

from asictl.build import build_file
from asictl.diagnostics import DiagnosticError, render_text
from asictl.errors import UserError
from asictl.files import refuse_inputs, write_output
from asictl.il.ast import key
from asictl.observe.condition import Condition, ConditionError, parse_condition
from asictl.observe.operands import SETTABLE, Operand, check_value, parse_operand
from asictl.observe.symbols import SymbolTable, load_symbols, symbols_for
from asictl.readers.units import duration_ms, format_duration, format_instant
from asictl.sim.engine import Simulation, variables_of
from asictl.sim.plant import Model, read_model
from asictl.sim.scenario import MAX_TIME_MS, Scenario, parse_slave
from asictl.sim.trace import Trace, to_csv, to_vcd, write_plot
from asictl.source import read_source, symbols_path

__all__ = ["ExpectationFailed", "LoadError", "Plc", "TimedOut"]

#: How many rows of the trace a time-out shows.
TRACE_ROWS = 20
#: A Python plant model: ``fn(elapsed_ms)`` or ``fn(plc, elapsed_ms)``.
CycleFunction = Callable[[float], object] | Callable[["Plc", float], object]


def _positional(fn: Callable[..., object]) -> int:
    """How many positional arguments ``fn`` takes (1 where that cannot be seen)."""
    try:
        parameters = inspect.signature(fn).parameters.values()
    except (TypeError, ValueError):
        return 1
    kinds = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    return sum(1 for p in parameters if p.kind in kinds)


class LoadError(Exception):
    """The program (or its symbol table) has errors; the message holds the diagnostics
    as ``asictl check`` prints them."""


class ExpectationFailed(AssertionError):
    """An operand did not hold what the test expected."""


class TimedOut(ExpectationFailed):
    """``run_until``'s condition did not hold in time; ``trace`` is the trace of the
    wait (the message shows its last rows)."""

    def __init__(self, message: str, trace: Trace) -> None:
        super().__init__(message)
        self.trace = trace


def _ms(value: str | float, what: str) -> float:
    """A duration: ``"250ms"``, ``"2s"`` or a number of milliseconds (as in a scenario
    file: ``readers.units.duration_ms``), at most 24 h."""
    return duration_ms(value, what=f"a {what}", limit_ms=MAX_TIME_MS)


def _caller() -> str:
    """``file.py:LINE`` of the first caller outside this module (the test's line)."""
    frame = inspect.currentframe()
    while frame is not None and frame.f_code.co_filename == __file__:
        frame = frame.f_back
    if frame is None:
        return "<test>"
    return f"{Path(frame.f_code.co_filename).name}:{frame.f_lineno}"


class _Place:
    """``plant.read_model``'s view of a table given in Python: problems raise."""

    def __init__(self, variables: Mapping[str, int], symbols: SymbolTable) -> None:
        self.variables = variables
        self.symbols = symbols
        self.problems: list[str] = []

    def problem(self, message: str, key: str | None = None) -> None:
        self.problems.append(message)

    def condition_problem(self, error: ConditionError, key: str) -> None:
        self.problems.append(f"{key}: {error}")

    def operand(self, text: str) -> Operand:
        return parse_operand(text, self.variables, self.symbols)

    def condition(self, text: str) -> Condition:
        return parse_condition(text, self.variables, self.symbols)


class Plc:
    """One program on one fresh emulated master, in virtual time."""

    def __init__(self, simulation: Simulation, program: Path, cycle_ms: float | None,
                 variables: Mapping[str, int], symbols: SymbolTable) -> None:
        """Made by ``Plc.load``."""
        self._sim = simulation
        self.program = program
        self.cycle_ms = cycle_ms
        self._variables = variables
        self.symbols = symbols
        #: each callback with the time of its last call
        self._callbacks: list[tuple[Callable[[float], object], list[float]]] = []
        self._closed = False
        self._names: dict[str, int] = {}
        #: a plant model (``on_cycle``) is being called
        self._in_model = False

    # ------------------------------------------------------------------ making one

    @classmethod
    def load(
        cls,
        path: str | Path,
        cycle_ms: float | None = 5,
        slaves: Mapping[int, str] | None = None,
        symbols: str | Path | Mapping[str, str] | SymbolTable | None = None,
        *,
        lib: tuple[str | Path, ...] = (),
    ) -> Plc:
        """Build ``path`` (IL source, [RAW] file or .hex image) and download it.

        ``cycle_ms``: the program cycle period (None: every AS-i cycle); ``slaves``: the
        bus, ``{16: "iiio,1"}`` (default: the program's [SETUP]); ``symbols``: a symbol
        table file, a mapping name -> operand, or None for ``NAME.symbols.toml`` beside
        the program if there is one. ``LoadError`` if the program has errors,
        ``ValueError`` for a bad argument."""
        program = Path(path)
        if cycle_ms is not None and (isinstance(cycle_ms, bool) or not isinstance(
                cycle_ms, int | float) or not 0.1 <= cycle_ms <= 10_000):
            raise ValueError(f"cycle_ms is 0.1 to 10000 (or None), not {cycle_ms!r}")
        try:
            built = build_file(program, lib=lib)
        except UserError as exc:
            raise LoadError(str(exc)) from None
        if built.has_errors or built.image is None:
            raise LoadError(built.render())
        variables = variables_of(built.image.pmap)
        table = _symbols(program, symbols, variables)
        specs = None
        if slaves is not None:
            if not isinstance(slaves, Mapping):
                raise TypeError("slaves is a mapping of addresses to slave specs, "
                                f"{{16: 'iiio,1'}}, not {slaves!r}")
            specs = [parse_slave(address, spec) for address, spec in slaves.items()]
        scenario = Scenario(str(program), program, cycle_ms, specs, [])
        simulation = Simulation(built, scenario, duration_ms=math.inf, trace=True,
                                symbols=table)
        simulation.load()
        return cls(simulation, program, cycle_ms, variables, table)

    def close(self) -> None:
        """The end of the test: the master is gone, using it is an error."""
        self._closed = True
        self._callbacks.clear()

    def __enter__(self) -> Plc:
        return self

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self.close()

    # ------------------------------------------------------------------ operands

    def operand(self, text: str) -> Operand:
        """The operand ``text`` names (an operand as in IL, ``CV n``, ``TV n``, or a
        symbol); ``ValueError`` if none, ``TypeError`` if ``text`` is no text."""
        if not isinstance(text, str):
            raise TypeError(f"an operand is a text such as 'I 1.0', not {_shown(text)}")
        return parse_operand(text, self._variables, self.symbols)

    def __getitem__(self, text: str) -> int:
        """The value now: inputs as the slaves deliver them, outputs as the slaves
        receive them (0 while the program is stopped), flags, timers' and counters'
        values, the program's memory."""
        self._open()
        return self._sim.read(self.operand(text))

    def __setitem__(self, text: str, value: int | bool) -> None:
        self.set(text, value)

    def set(self, text: str, value: int | bool) -> None:
        """Set an input (as the slave delivers it) or a flag (as a host writes it),
        seen by every program cycle from now on; not one that a plant model drives."""
        self._open()
        operand = self.operand(text)
        if not operand.settable:
            raise ValueError(f"'{text}' cannot be set: {SETTABLE}")
        driver = self._sim.plant.driver_of(operand)
        if driver is not None:
            raise ValueError(f"'{text}' is driven by the plant model {driver.name}")
        self._sim.set(operand, check_value(_whole(value, text), operand, text))

    @property
    def time_ms(self) -> float:
        """Master time since time 0 (the first program cycle), in milliseconds."""
        return self._sim.now_ms() if self._sim.started else 0.0

    @property
    def stops(self) -> list[str]:
        """The program's stops so far: ``at 55 ms: program stopped: ...``."""
        return [s.reported for s in self._sim.result.stops]

    # ------------------------------------------------------------------ plant models

    def on_cycle(self, fn: CycleFunction) -> CycleFunction:
        """Call ``fn(elapsed_ms)`` (or ``fn(plc, elapsed_ms)``, if it takes two
        arguments) after every program cycle (every ``cycle_ms``; every millisecond with
        ``cycle_ms=None``), with the time since its previous call: a plant model in
        Python, which reads outputs (``plc["Q 2.0"]``) and sets inputs. What it sets is
        seen by the next cycle; it returns nothing (a value returned, a coroutine of an
        ``async def``, would be lost: ``TypeError``). Returns ``fn`` (a decorator)."""
        self._open()
        given: Callable[..., object] = fn
        call = functools.partial(given, self) if _positional(given) >= 2 else given
        self._callbacks.append((call, [self.time_ms]))  # its first call counts from now
        return fn

    def add_plant(self, type: str, **table: Any) -> Model:
        """A scenario's plant model (docs/simulation.md), its table given as keywords:
        ``plc.add_plant("cylinder", extend="Q 2.0", extended="I 1.0", stroke_ms=300)``
        (a rule's ``else`` is ``else_``); added before time starts. Returns the model
        (its state: ``position``, ``level``, ``parts`` ...); ``ValueError`` says what is
        wrong with the table."""
        self._open()
        place = _Place(self._variables, self.symbols)
        count = self._names.get(type, 0) + 1
        if "else_" in table:
            table["else"] = table.pop("else_")
        model = read_model({"type": type, **table}, f"{type}{count}", place)
        if model is None:
            raise ValueError("; ".join(place.problems))
        self._sim.add_model(model)
        self._names[type] = count
        return model

    # ------------------------------------------------------------------ time

    def run(self, duration: str | float) -> None:
        """Let ``duration`` of master time pass (``"250ms"``, ``"2s"``, or milliseconds)."""
        self._time_may_pass()
        self._advance(self.time_ms + _ms(duration, "duration"), None)

    def run_until(self, condition: str, timeout: str | float = "10s") -> float:
        """Run until ``condition`` holds after a program cycle (``"Q 2.0 == 1"``, ``"Done
        and not I 1.2"``: the language of a plant rule's ``when``) and return the time;
        ``TimedOut``, with the trace of the wait, if it does not within ``timeout``."""
        __tracebackhide__ = True
        self._time_may_pass()
        test = parse_condition(condition, self._variables, self.symbols)
        if self._sim.started and test(self._sim.read):
            return self.time_ms
        start = self.time_ms
        end = start + _ms(timeout, "timeout")
        if self._advance(end, test):
            return self.time_ms
        trace = self._sim.trace_now().window(start, end)
        message = (f"{_caller()}: at {format_instant(self.time_ms)}: '{condition}' did not "
                   f"hold within {format_duration(end - start)} (from {format_instant(start)})")
        lanes = {lane.name for lane in self._sim.plant.lanes()}
        raise TimedOut("\n".join([message, *self.stops, *_last_rows(trace, test, lanes)]),
                       trace)

    def expect(self, text: str, value: int | bool) -> None:
        """Check an operand now; ``ExpectationFailed`` reads as a scenario's failure:
        ``test_seq.py:14: at 250 ms: Q 2.0 expected 1, got 0``."""
        __tracebackhide__ = True
        wanted = _whole(value, text)
        got = self[text]
        if got != wanted:
            lines = [f"{_caller()}: at {format_instant(self.time_ms)}: {text} expected {wanted}, "
                     f"got {got}", *self.stops]
            raise ExpectationFailed("\n".join(lines))

    def trace(self, vcd: str | Path | None = None, csv: str | Path | None = None,
              plot: str | Path | None = None) -> Trace:
        """The trace so far (the program's operands, the models' lanes), written as a
        value change dump, CSV or a timing diagram where asked (as ``asictl sim
        --vcd/--csv/--plot``; never over the program)."""
        trace = self._sim.trace_now()
        inputs = [self.program]
        if vcd is not None:
            write_output(vcd, to_vcd(trace, comment="asictl.testing"), inputs=inputs)
        if csv is not None:
            write_output(csv, to_csv(trace), inputs=inputs)
        if plot is not None:
            refuse_inputs(plot, inputs)
            write_plot(trace, Path(plot), title=self.program.name)
        return trace

    # ------------------------------------------------------------------ inside

    def _open(self) -> None:
        if self._closed:
            raise RuntimeError(f"{self.program}: this Plc is closed")

    def _time_may_pass(self) -> None:
        """A plant model is called between two program cycles: letting time pass from
        there would run cycles inside a cycle (and recurse until Python gives up)."""
        self._open()
        if self._in_model:
            raise RuntimeError("a plant model (on_cycle) cannot let time pass: it is "
                               "called after each program cycle; set inputs and return")

    def _start(self) -> None:
        if not self._sim.started:
            self._sim.begin()
            self._call_back()

    def _call_back(self) -> None:
        now = self.time_ms
        self._in_model = True
        try:
            for fn, last in list(self._callbacks):
                elapsed, last[0] = now - last[0], now
                _returns_nothing(fn(elapsed), fn)
        finally:
            self._in_model = False

    def _advance(self, end: float, test: Condition | None) -> bool:
        """Run to ``end`` (the plant models' state then as of the time reached)."""
        held = self._run(end, test)
        self._sim.evaluate_plant()
        return held

    def _run(self, end: float, test: Condition | None) -> bool:
        """Run to ``end``, program cycle by program cycle while callbacks or ``test``
        need to look after each; True when ``test`` held (then time stops there)."""
        self._start()
        sim = self._sim
        if test is not None and test(sim.read):
            return True
        if not self._callbacks and test is None:
            sim.run_to(end)
            return False
        period = round((self.cycle_ms or 1.0) * 1000)
        end_us = round(end * 1000)
        while True:
            now = round(sim.now_ms() * 1000)
            step = (now // period + 1) * period  # the next program cycle
            if step > end_us:
                sim.run_to(end)
                return False
            sim.run_to(step / 1000)
            self._call_back()
            if test is not None and test(sim.read):
                return True


def _returns_nothing(returned: object, fn: Callable[..., object]) -> None:
    """A plant model acts by setting inputs; what it returns would be dropped unseen
    (the inputs of a model that returns them, the whole body of an ``async def``)."""
    if returned is None:
        return
    if inspect.iscoroutine(returned):
        returned.close()  # never to run: no "never awaited" warning on top
    name = getattr(fn, "__name__", None) or getattr(getattr(fn, "func", None), "__name__", "")
    raise TypeError(f"the plant model {name or repr(fn)} (on_cycle) sets inputs and returns "
                    f"nothing; it returned {_shown(returned)}")


def _shown(value: object) -> str:
    """``value`` for a message: its type and a short repr."""
    text = repr(value)
    return f"{type(value).__name__} {text[:60] + '...' if len(text) > 60 else text}"


def _whole(value: object, text: str) -> int:
    """A value to set: a whole number or a bool; 0.5 is no bit and 1.7 no nibble value,
    so a fraction is refused rather than cut off."""
    if isinstance(value, bool | int):
        return int(value)
    if isinstance(value, float):
        if value.is_integer():
            return int(value)
        raise ValueError(f"'{text}' takes a whole number, not {value!r}")
    raise TypeError(f"'{text}' takes a whole number, not {_shown(value)}")


def _last_rows(trace: Trace, test: Condition, lanes: set[str]) -> list[str]:
    """The last rows of ``trace`` for the operands of ``test``, the outputs and the
    ``lanes`` of the models: what a time-out shows."""
    wanted = {str(o) for o in test.operands} | lanes
    signals = [s for s in trace.signals if s.operand in wanted or s.operand.startswith("Q ")]
    if not signals:
        return []
    shown = Trace(signals, end_ms=trace.end_ms, start_ms=trace.start_ms)
    rows = to_csv(shown).splitlines()
    header, body = rows[0], rows[1:]
    cut = [f"... {len(body) - TRACE_ROWS} earlier rows"] if len(body) > TRACE_ROWS else []
    return ["trace of the wait:", header, *cut, *body[-TRACE_ROWS:]]


def _symbols(program: Path, given: str | Path | Mapping[str, str] | SymbolTable | None,
             variables: Mapping[str, int]) -> SymbolTable:
    def check(text: str) -> str:
        return str(parse_operand(text, variables))

    try:
        if given is None:
            return symbols_for(program, check)
        if isinstance(given, SymbolTable):
            return given
        if isinstance(given, str | Path):
            return load_symbols(given, check)
    except DiagnosticError as exc:
        path = str(given) if isinstance(given, str | Path) else str(symbols_path(program))
        with_text = {path: read_source(path).text} if Path(path).is_file() else {}
        raise LoadError(render_text(exc.diagnostics, with_text)) from None
    entries = {key(name.strip()): (name.strip(), check(text)) for name, text in given.items()}
    return SymbolTable("<symbols>", entries)
