"""One simulation from files to report: what ``sim``, ``test``, the pytest plugin and the
debugger share.

``prepare`` reads and checks everything (program, symbol table, scenario, command-line
sets) and raises ``Invalid`` with the rendered diagnostics when something is wrong;
``simulate`` runs it; ``events``, ``summary`` and ``as_json`` report it. ``run_file``
does all of it for one scenario file and never raises, so that one bad scenario is one
ERROR row of ``asictl test`` and the other scenarios still run (in worker processes, as
``test -j`` does).
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from asictl import __version__
from asictl.build import Build, build_file
from asictl.diagnostics import DiagnosticError, render_text
from asictl.errors import ExitCode, UserError
from asictl.observe.coverage import Coverage
from asictl.observe.operands import SETTABLE, parse_assignment, parse_operand
from asictl.observe.symbols import SymbolTable, symbols_for
from asictl.readers.units import format_duration, format_instant
from asictl.sim import SUFFIX
from asictl.sim.engine import SimResult, Simulation, variables_of
from asictl.sim.plant import Plant
from asictl.sim.scenario import (
    Scenario,
    Step,
    load_scenario,
    scenario_program,
)
from asictl.source import read_source

#: How long a program runs when no scenario says.
DEFAULT_DURATION_MS = 10_000.0


class Invalid(Exception):
    """Bad input: ``text`` holds the rendered diagnostics, ``message`` one line; a
    program with errors exits ``FAILED`` as ``check`` does, a bad scenario ``USAGE``."""

    def __init__(self, text: str, message: str = "invalid scenario or program",
                 exit_code: ExitCode = ExitCode.USAGE) -> None:
        super().__init__(message)
        self.text = text
        self.message = message
        self.exit_code = exit_code


def program_for(scenario: Path) -> Path:
    """A scenario without ``program`` belongs to the program of the same name beside it."""
    return scenario.with_name(scenario.name[: -len(SUFFIX)] + ".asi")


def scenario_for(program: Path) -> Path:
    """The scenario beside a program: ``blink.asi`` -> ``blink.scenario.toml``."""
    return program.with_name(program.stem + SUFFIX)


def _texts(*paths: Path | None) -> dict[str, str]:
    texts = {}
    for path in paths:
        if path is not None:
            with contextlib.suppress(UserError):
                texts[str(path)] = read_source(path).text
    return texts


def _invalid(exc: DiagnosticError, texts: dict[str, str]) -> Invalid:
    return Invalid(render_text(exc.diagnostics, texts))


@dataclass
class Prepared:
    program: Path
    build: Build
    scenario: Scenario
    symbols: SymbolTable
    #: the build's warnings, rendered
    notes: str = ""
    #: how long to run
    end_ms: float = 0.0
    #: steps after ``end_ms`` that will not run (with --allow-partial)
    cut_steps: int = 0


def prepare(
    program: Path | None,
    scenario_path: Path | None,
    *,
    lib: Iterable[str] = (),
    sets: Iterable[str] = (),
    duration_ms: float | None = None,
    allow_partial: bool = False,
) -> Prepared:
    """Load, check and compile everything a simulation needs; raises ``Invalid`` or
    ``UserError``."""
    if scenario_path is not None:
        try:
            named = scenario_program(read_source(scenario_path))
        except DiagnosticError as exc:
            raise _invalid(exc, _texts(scenario_path)) from None
        program = program or named
        if program is None and scenario_path.name.endswith(SUFFIX):
            program = program_for(scenario_path)
    if program is None:
        raise UserError("no program: name one, or give the scenario a 'program = \"...\"' line")
    built = build_file(program, lib=lib)
    if built.has_errors or built.image is None:
        raise Invalid(built.render(), "the program has errors", ExitCode.FAILED)
    variables = variables_of(built.image.pmap)

    def check(text: str) -> str:
        return str(parse_operand(text, variables))

    try:
        symbols = symbols_for(program, check)
    except DiagnosticError as exc:
        raise _invalid(exc, _texts(program.with_name(program.stem + ".symbols.toml"))) from None
    if scenario_path is not None:
        try:
            scenario = load_scenario(scenario_path, variables, symbols)
        except DiagnosticError as exc:
            raise _invalid(exc, _texts(scenario_path)) from None
    else:
        scenario = Scenario("<command line>", program, None, None, [])
    # an empty file is a valid scenario; said, since it runs and expects nothing
    empty = (f"{scenario_path}: note: no steps: nothing is set or expected at a time\n"
             if scenario_path is not None and not scenario.steps else "")
    extra = _command_line_sets(sets, variables, symbols)
    if extra.set:
        plant = Plant(scenario.plants)
        for operand, _, _ in extra.set:
            driver = plant.driver_of(operand)
            if driver is not None:
                written = extra.written.get((0, str(operand)), str(operand))
                raise UserError(f"--set '{written}': driven by the plant model {driver.name} "
                                "of the scenario")
        scenario.steps.append(extra)
    last = scenario.end_ms
    if duration_ms is None:
        end = last if scenario_path is not None else max(last, DEFAULT_DURATION_MS)
    else:
        end = duration_ms
    cut = sum(1 for s in scenario.steps if s.at_ms > end)
    if cut and not allow_partial:
        raise UserError(
            f"--duration {format_instant(end)} ends before the scenario's last step at "
            f"{format_instant(last)} "
            f"({cut} step{'s' if cut != 1 else ''} would not run); run longer, or pass "
            "--allow-partial"
        )
    return Prepared(Path(program), built, scenario, symbols, built.render() + empty, end, cut)


def _command_line_sets(
    sets: Iterable[str], variables: dict[str, int], symbols: SymbolTable
) -> Step:
    """``--set "I 1.0=1"``: one step at time 0."""
    step = Step(0.0, 0)
    for text in sets:
        try:
            assignment = parse_assignment(text, variables, symbols)
            if not assignment.operand.settable:
                raise ValueError(f"'{assignment.written}' cannot be set: {SETTABLE}")
        except ValueError as exc:
            raise UserError(f"--set '{text}': {exc}") from None
        operand = assignment.operand
        step.set.append((operand, assignment.value, 0))
        if assignment.written != str(operand):
            step.written[(0, str(operand))] = assignment.written
    return step


@dataclass
class Run:
    prepared: Prepared
    result: SimResult
    seconds: float
    #: what the trace could not show, for standard error
    note: str = ""

    @property
    def scenario(self) -> Scenario:
        return self.prepared.scenario


def simulate(
    prepared: Prepared,
    *,
    trace: bool = False,
    signals: list[str] | None = None,
    il_trace: bool = False,
    window: tuple[float, float | None] = (0.0, None),
    coverage: bool = False,
    coverage_counts: bool = True,
    fail_fast: bool = False,
    progress: Callable[[float, float], None] | None = None,
) -> Run:
    """Run the prepared scenario; ``progress(now_ms, end_ms)`` hears how far it is, once
    a second of master time."""
    start = time.perf_counter()
    try:
        simulation = Simulation(
            prepared.build, prepared.scenario, duration_ms=prepared.end_ms, trace=trace,
            signals=signals, symbols=prepared.symbols, il_trace=il_trace, window=window,
            coverage=coverage, coverage_counts=coverage_counts, fail_fast=fail_fast,
            progress=progress,
        )
        result = simulation.run()
        if any(f.step.within_ms for f in result.failures):
            _name_writers(prepared, result)
    except DiagnosticError as exc:
        raise _invalid(exc, {**prepared.build.texts, **_texts(Path(prepared.scenario.file))}) \
            from None
    note = f"asictl: note: {prepared.program}: {simulation.untraced}\n" if simulation.untraced \
        else ""
    return Run(prepared, result, time.perf_counter() - start, note)


def _name_writers(prepared: Prepared, result: SimResult) -> None:
    """Run once more, watching the lines that write what the tolerance windows expect,
    to name the line that last wrote each failed one (the run is deterministic: the
    failures are the same, and the first run's traces stay as they were)."""
    again = Simulation(prepared.build, prepared.scenario, duration_ms=prepared.end_ms,
                       symbols=prepared.symbols, track_writers=True).run()
    writers = {(f.line, str(f.operand)): f.writer for f in again.failures}
    for failure in result.failures:
        failure.writer = writers.get((failure.line, str(failure.operand)), "")


def events(run: Run) -> list[str]:
    """Failures, stops and firmware refusals, in the order they happened."""
    file = run.scenario.file
    timed: list[tuple[float, int, str]] = []
    for f in run.result.failures:
        timed.append((f.at_ms, 0, f"{file}:{f.line}: {f}"))
    for s in run.result.stops:
        timed.append((s.at_ms, 1, f"{file}: {s.reported}"))
    for r in run.result.refusals:
        timed.append((r.at_ms, 2, f"{file}: at {format_instant(r.at_ms)}: note: {r.text}"))
    return [text for _, _, text in sorted(timed, key=lambda item: item[:2])]


def final_lines(run: Run) -> list[str]:
    """The outputs, counters and timers the program left at the end: what a run without
    expectations shows (one with them shows its failures instead)."""
    final = run.result.final
    if final is None:
        return []
    rows = [f"at {format_instant(final.at_ms)}:"]
    if final.outputs:
        rows.append("  outputs   " + "  ".join(
            f"Q {a} = {v:04b}" for a, v in final.outputs.items()))
    if final.counters:
        rows.append("  counters  " + "  ".join(f"C {n} = {v}" for n, v in final.counters.items()))
    if final.timers_ms:
        rows.append("  timers    " + "  ".join(
            f"T {n} = {v} ms" for n, v in final.timers_ms.items()))
    if len(rows) == 1:
        rows.append("  no outputs, counters or timers")
    return rows


def summary(run: Run) -> str:
    r = run.result
    failed = len(r.failures)
    cut = run.prepared.cut_steps
    partial = f" ({cut} step{'s' if cut != 1 else ''} after the end not run)" if cut else ""
    return (
        f"{r.checked} expectation{'s' if r.checked != 1 else ''}, {failed} failed; "
        f"{format_duration(r.end_ms)} of master time in {format_duration(run.seconds * 1000)}"
        f"{partial}"
    )


def as_json(run: Run) -> dict[str, Any]:
    r = run.result
    return {
        "scenario": run.scenario.file,
        "passed": r.passed,
        "checked": r.checked,
        "failures": [
            {"line": f.line, "at_ms": f.at_ms, "operand": f.written or str(f.operand),
             "expected": f.expected, "got": f.got,
             **({"within_ms": f.step.within_ms, "last_written_by": f.writer}
                if f.step.within_ms else {})}
            for f in r.failures
        ],
        "stops": [{"at_ms": s.at_ms, "reason": s.reason, "where": s.where} for s in r.stops],
        "notes": [{"at_ms": n.at_ms, "text": n.text} for n in r.refusals],
        "end_ms": r.end_ms,
        "final": r.final.as_json() if r.final is not None else None,
        "wall_s": round(run.seconds, 3),
    }


# ---------------------------------------------------------------------- asictl test


@dataclass
class Outcome:
    """What ``asictl test`` shows of one scenario file; plain data for worker processes."""

    path: str
    status: str  # PASS, FAIL, ERROR
    summary: str = ""
    events: list[str] = field(default_factory=list)
    #: diagnostics and notes for standard error
    stderr: str = ""
    #: the ERROR row's reason
    message: str = ""
    seconds: float = 0.0
    #: an internal error (a bug), not bad input
    bug: bool = False
    #: an ERROR row's exit status: FAILED for a program with errors, else USAGE
    exit_code: int = ExitCode.USAGE
    #: its worker process died (the OOM killer, a signal): a result, not bad input
    died: bool = False
    markers: list[str] = field(default_factory=list)
    #: failures as (line, text) for test runners that show the scenario line
    failures: list[tuple[int, str]] = field(default_factory=list)
    #: program stops, ``at 55 ms: program stopped: ...``
    stops: list[str] = field(default_factory=list)
    #: the program file the scenario ran (none for an ERROR row)
    program: str = ""
    #: its symbol table, operand -> name (for what coverage lists as missing)
    names: dict[str, str] = field(default_factory=dict)
    #: what the scenario reached of its program, when asked for
    coverage: Coverage | None = None


#: the ERROR row of a scenario whose worker process died, twice (``asictl test -j``)
WORKER_DIED = ("its worker process died (killed by a signal or the out-of-memory killer), "
               "also when run again alone")


def run_file(path: str, lib: tuple[str, ...] = (), coverage: bool = False) -> Outcome:
    """Run one scenario file; whatever goes wrong is in the outcome, nothing is raised."""
    try:
        prepared = prepare(None, Path(path), lib=lib)
        run = simulate(prepared, coverage=coverage)
    except Invalid as exc:
        return Outcome(path, "ERROR", stderr=exc.text, message=exc.message,
                       exit_code=exc.exit_code)
    except UserError as exc:
        return Outcome(path, "ERROR", message=str(exc))
    except Exception as exc:  # one bug must not end a whole test run: an ERROR row
        return Outcome(
            path, "ERROR", bug=True,
            message=f"internal error (this is a bug in asictl {__version__}): "
                    f"{type(exc).__name__}: {exc}",
        )
    return Outcome(
        path, "PASS" if run.result.passed else "FAIL", summary(run), events(run),
        prepared.notes + run.note, seconds=run.seconds, markers=list(prepared.scenario.markers),
        failures=[(f.line, str(f)) for f in run.result.failures],
        stops=[s.reported for s in run.result.stops],
        program=str(prepared.program), coverage=run.result.coverage,
        names={text: name for name, text in prepared.symbols.entries.values()},
    )


def find_scenarios(paths: Iterable[Path]) -> list[Path]:
    """The scenario files PATHs name: files as given, folders searched (default: the
    current folder); raises ``UserError`` for a path that is not there."""
    found: list[Path] = []
    for path in list(paths) or [Path()]:
        if path.is_dir():
            found.extend(sorted(p for p in path.rglob(f"*{SUFFIX}") if p.is_file()))
        elif path.is_file():
            found.append(path)
        else:
            raise UserError(f"{path}: no such file or directory")
    return found


def default_jobs() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
               else os.cpu_count() or 1)

