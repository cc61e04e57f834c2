"""One ``asictl prove`` of one properties file: load the program and its properties,
find the master's setup and the simulator's clock phase, decide every property and
write the counterexamples and witnesses.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field
from pathlib import Path

from asictl.build import Build, build_file
from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity, render_text
from asictl.errors import ExitCode, UserError
from asictl.files import real_path, write_atomic
from asictl.il.pragmas import read_directives
from asictl.observe.names import named
from asictl.observe.operands import parse_operand
from asictl.observe.symbols import SymbolTable, load_symbols, symbols_for
from asictl.platform.master import TICK_US, asi_cycle_us
from asictl.prove import DEPTH, MAX_DEPTH
from asictl.prove.counterexample import MARK, expectations, file_name, scenario_text
from asictl.prove.engine import Machine, Outcome, Setup, Verdict
from asictl.prove.props import Properties, program_for, read_properties
from asictl.prove.scope import Scope
from asictl.prove.symbolic import UNROLL, TimeLimit, Unmodelled
from asictl.readers.units import Cycles, UnitError, format_duration
from asictl.sim.engine import Simulation, variables_of
from asictl.sim.scenario import Scenario, SlaveSpec, read_scenario, scenario_program
from asictl.source import SourceText, read_source


class Invalid(Exception):
    """Bad input: ``text`` holds the rendered diagnostics; a program with errors exits
    ``FAILED`` as ``check`` does, a bad properties file ``USAGE``."""

    def __init__(self, text: str, exit_code: ExitCode = ExitCode.USAGE) -> None:
        super().__init__(text)
        self.text = text
        self.exit_code = exit_code


@dataclass
class Report:
    properties: Path
    program: Path
    cycle_ms: float
    slaves: tuple[int, ...]
    invariants: list[str]
    loops: list[tuple[int, int]]
    outcomes: list[Outcome] = field(default_factory=list)
    #: property name -> the scenario written for it
    written: dict[str, Path] = field(default_factory=dict)
    seconds: float = 0.0
    #: the warnings about the properties (W431), rendered with their source lines
    warnings: str = ""
    #: the program's symbol table: how the verdicts name operands (observe/names.py)
    symbols: SymbolTable = field(default_factory=SymbolTable)

    @property
    def passed(self) -> bool:
        return all(o.verdict.good for o in self.outcomes)


def _texts(*paths: Path) -> dict[str, str]:
    texts = {}
    for path in paths:
        with contextlib.suppress(UserError):
            texts[str(path)] = read_source(path).text
    return texts


def load(properties: Path, program: Path | None, lib: tuple[str, ...],
         symbols: Path | None = None) -> tuple[Properties, Path, Build]:
    """The properties file and the program it is about, both checked; the names are
    those of ``symbols``, else of the table beside the program."""
    source = read_source(properties)
    try:
        named = read_properties(source).program  # the program line, before its symbols
    except DiagnosticError as exc:
        if any(d.code is not ScenarioCode.CONDITION for d in exc.diagnostics):
            raise Invalid(render_text(exc.diagnostics, _texts(properties))) from None
        named = scenario_program(source)  # the conditions wait for the symbols, below
    program = program or named or program_for(properties)
    built = build_file(program, lib=lib)
    if built.has_errors or built.program is None:
        raise Invalid(built.render() or f"{program}: no IL program (an image has no source "
                                         "to prove)\n",
                      ExitCode.FAILED if built.has_errors else ExitCode.USAGE)
    variables = {} if built.image is None else variables_of(built.image.pmap)

    def check(text: str) -> str:
        return str(parse_operand(text, variables))

    try:
        table = (symbols_for(program, check) if symbols is None
                 else load_symbols(symbols, check))
        props = read_properties(source, variables, table, Scope.of(built.program))
    except DiagnosticError as exc:
        shown = [properties, program] + ([symbols] if symbols is not None else [])
        raise Invalid(render_text(exc.diagnostics, _texts(*shown))) from None
    return props, program, built


def setup_of(props: Properties, built: Build) -> tuple[Setup, float]:
    """The bus, the cycle time and the host-written flags; and the cycle in ms."""
    program = built.program
    assert program is not None
    if props.slaves is not None:
        slaves = tuple(sorted(s.address for s in props.slaves))
    else:
        slaves = tuple(sorted({s.address for s in program.slaves}))
    cycle_us = (round(props.cycle_ms * 1000) if props.cycle_ms is not None
                else asi_cycle_us(len(slaves)))
    directives = read_directives(program.sources)
    host = tuple(operand for operand, _ in directives.host_flags)
    phase = simulator_phase(built, cycle_us, props.slaves)
    return Setup(slaves, cycle_us, host, phase), cycle_us / 1000


def simulator_phase(built: Build, cycle_us: int,
                    slaves: list[SlaveSpec] | None = None) -> int | None:
    """The time from time 0 to the first 10 ms tick in ``asictl sim`` of this program
    and master (``slaves`` default to its [SETUP]), so that counterexamples about timers
    replay tick for tick; None when the simulator cannot start it."""
    if built.image is None:
        return None
    scenario = Scenario("<phase>", None, cycle_us / 1000, slaves, [])
    simulation = Simulation(built, scenario)
    simulation.start()
    if not simulation.started:
        return None
    board = simulation.board
    phase = board.next_tick_us - board.now_us + round(simulation.now_ms() * 1000)
    return phase if 1 <= phase <= TICK_US else None


def replays(built: Build, scenario: SourceText, witness: bool,
            symbols: SymbolTable) -> bool:
    """Whether a counterexample's scenario fails in the simulator at its last step only
    (a witness's passes), as ``asictl sim`` of the written file will."""
    assert built.image is not None
    try:
        read = read_scenario(scenario, variables_of(built.image.pmap), symbols)
    except DiagnosticError:
        return False
    result = Simulation(built, read).run()
    if witness:
        return result.passed
    last = max(step.at_ms for step in read.steps)
    return bool(result.failures) and {f.at_ms for f in result.failures} == {last}


def cycles_of(depth: int | Cycles, cycle_ms: float) -> int:
    """``depth`` in cycles of ``cycle_ms``; more than ``MAX_DEPTH`` is a ``UserError``."""
    if isinstance(depth, int):
        return depth
    try:
        return depth.of(cycle_ms, most=MAX_DEPTH)
    except UnitError as exc:
        raise UserError(f"--depth: {exc}") from None


def prove(properties: Path, *, program: Path | None = None, lib: tuple[str, ...] = (),
          depth: int | Cycles | None = None, timeout_s: float = 30.0,
          out_dir: Path | None = None, force: bool = False, unroll: int = UNROLL,
          symbols: Path | None = None) -> Report:
    """Decide every property of a properties file; write what was found as scenarios.
    ``depth`` is cycles, or a time the program's cycle time turns into cycles (default
    ``DEPTH``; given, it bounds the concrete runs too, ``prove/falsify.py``);
    ``symbols`` a symbol table other than the one beside the program."""
    start = time.monotonic()
    props, program_path, built = load(properties, program, lib, symbols)
    setup, cycle_ms = setup_of(props, built)
    horizon = None if depth is None else cycles_of(depth, cycle_ms)
    depth = DEPTH if horizon is None else horizon
    assert built.program is not None
    directory = out_dir if out_dir is not None else properties.parent

    def replay(outcome: Outcome) -> bool:
        target = directory / file_name(properties, outcome.prop)
        text = scenario_text(props, program_path, target, outcome.prop, outcome,
                             machine.cycle.host_masks, cycle_ms,
                             expectations(outcome.prop, outcome, outcome.values))
        return replays(built, SourceText(str(target), text, text.encode()),
                       outcome.verdict is Verdict.REACHED, props.symbols)

    try:  # the limit holds from the start: reading and building the model count
        machine = Machine(built.program, setup, props.assume, props.properties,
                          unroll=unroll, label=lambda text: named(text, props.symbols),
                          deadline=start + timeout_s, replay=replay)
    except Unmodelled as exc:
        raise Invalid(render_text(
            [Diagnostic(Severity.ERROR, ScenarioCode.UNMODELLED, str(exc), exc.span)],
            built.texts)) from None
    except TimeLimit:
        return _out_of_time(props, properties, program_path, cycle_ms, setup, timeout_s,
                            start)
    machine.find_invariants(start + timeout_s)
    report = Report(properties, program_path, cycle_ms, setup.slaves,
                    list(machine.invariant_names),
                    [(loop.line, loop.bound) for loop in machine.cycle.loops],
                    symbols=props.symbols)
    if props.warnings:
        report.warnings = render_text(props.warnings, _texts(properties))
    pending: list[tuple[Path, str, str]] = []
    for number, prop in enumerate(props.properties):
        outcome = machine.decide(prop, depth=depth, timeout_s=timeout_s,
                                 since=start if number == 0 else None, horizon=horizon)
        report.outcomes.append(outcome)
        if outcome.trace is not None and outcome.verdict in (Verdict.REFUTED,
                                                             Verdict.REACHED):
            target = directory / file_name(properties, prop)
            expected = expectations(prop, outcome, outcome.values)
            text = scenario_text(props, program_path, target, prop, outcome,
                                 machine.cycle.host_masks, cycle_ms, expected)
            pending.append((target, prop.name, text))
    names: list[str | Path] = [properties, program_path, *built.program.sources]
    inputs = {real_path(p) for p in names if str(p) != "<stdin>"}
    for target, _, _ in pending:
        check_target(target, inputs, force)
    if pending:
        directory.mkdir(parents=True, exist_ok=True)
    for target, name, text in pending:
        write_atomic(target, text, follow_links=False)
        report.written[name] = target
    report.seconds = time.monotonic() - start
    return report


def _out_of_time(props: Properties, properties: Path, program: Path, cycle_ms: float,
                 setup: Setup, timeout_s: float, start: float) -> Report:
    """Every property unknown: the model was not built within the first one's limit."""
    seconds = time.monotonic() - start
    report = Report(properties, program, cycle_ms, setup.slaves, [], [], seconds=seconds,
                    symbols=props.symbols)
    note = (f"time limit ({format_duration(timeout_s * 1000)}) while building the model, "
            f"{format_duration(seconds * 1000)} since the start")
    report.outcomes = [Outcome(prop, Verdict.UNKNOWN, 0, seconds, note=note)
                       for prop in props.properties]
    return report


def check_target(target: Path, inputs: set[Path], force: bool) -> None:
    """Replace only what this command wrote before (its first line says so), and never
    through a symbolic link: one planted at a counterexample's name (by anyone who can
    write to the folder) would have the proof write wherever it points."""
    if target.is_symlink():
        raise UserError(f"{target}: is a symbolic link; a counterexample is not written "
                        "through one (remove it)")
    if real_path(target) in inputs:
        raise UserError(f"{target}: is an input of this proof; not overwritten")
    if force or not target.is_file():
        return
    try:
        with target.open("rb") as existing:
            first = existing.readline(200).decode("latin-1")
    except OSError as exc:
        raise UserError(f"{target}: cannot read: {exc.strerror or exc}") from None
    if not first.startswith(MARK):
        raise UserError(f"{target}: exists and is not a scenario asictl prove wrote; not "
                        "overwritten (use --force)")
