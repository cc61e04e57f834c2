"""``asictl sim`` and ``asictl test``: programs against scenarios, in virtual time."""

from __future__ import annotations

import contextlib
import json
import time
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree

import click

from asictl.build import build_file
from asictl.diagnostics import DiagnosticError, github_command, render_text
from asictl.errors import ExitCode, UserError
from asictl.files import refuse_inputs, write_output
from asictl.sim.engine import SimResult, Simulation, variables_of
from asictl.sim.scenario import Scenario, load_scenario, parse_duration
from asictl.sim.trace import to_csv, to_vcd, write_plot
from asictl.source import read_source

SUFFIX = ".scenario.toml"
#: How long a program runs when no scenario says.
DEFAULT_DURATION_MS = 10_000.0


class _Invalid(Exception):
    """Bad input, already reported."""


def _show(exc: DiagnosticError, texts: dict[str, str]) -> None:
    click.echo(render_text(exc.diagnostics, texts), nl=False, err=True)


def _texts(*paths: str | Path | None) -> dict[str, str]:
    texts = {}
    for path in paths:
        if path is not None:
            with contextlib.suppress(UserError):
                texts[str(path)] = read_source(path).text
    return texts


def _program_for(scenario_path: Path) -> Path:
    """A scenario without ``program`` belongs to the program of the same name beside it."""
    return scenario_path.with_name(scenario_path.name[: -len(SUFFIX)] + ".asi")


@dataclass
class _Run:
    program: Path
    scenario: Scenario
    result: SimResult
    seconds: float


def _run(
    program_path: Path | None, scenario_path: Path | None, *, duration_ms: float | None,
    trace: bool, lib: tuple[str, ...],
) -> _Run:
    """Load, check, compile and simulate; diagnostics are shown and raise ``_Invalid``."""
    scenario = None
    if scenario_path is not None:
        try:
            scenario = load_scenario(scenario_path)
        except DiagnosticError as exc:
            _show(exc, _texts(scenario_path))
            raise _Invalid from None
        program_path = program_path or scenario.program
        if program_path is None and scenario_path.name.endswith(SUFFIX):
            program_path = _program_for(scenario_path)
    if program_path is None:
        raise UserError("no program: name one, or give the scenario a 'program = \"...\"' line")
    built = build_file(program_path, lib=lib)
    click.echo(built.render(), nl=False, err=True)
    if built.has_errors or built.image is None:
        raise _Invalid
    if scenario_path is not None:
        try:  # again, now that the program's variables are known
            scenario = load_scenario(scenario_path, variables_of(built.image.pmap))
        except DiagnosticError as exc:
            _show(exc, _texts(scenario_path))
            raise _Invalid from None
    else:
        scenario = Scenario("<none>", Path(program_path), None, None, [])
        duration_ms = duration_ms if duration_ms is not None else DEFAULT_DURATION_MS
    start = time.perf_counter()
    try:
        simulation = Simulation(built, scenario, duration_ms=duration_ms, trace=trace)
        result = simulation.run()
    except DiagnosticError as exc:
        _show(exc, {**built.texts, **_texts(scenario_path)})
        raise _Invalid from None
    if simulation.untraced:
        click.echo(f"asictl: note: {program_path}: {simulation.untraced}", err=True)
    return _Run(Path(program_path), scenario, result, time.perf_counter() - start)


def _report_lines(run: _Run) -> list[str]:
    lines = [f"{run.scenario.file}:{f.line}: {f}" for f in run.result.failures]
    lines += [f"{run.scenario.file}: at {s.at_ms:g} ms: program stopped: {s.reason}"
              for s in run.result.stops]
    return lines


def _annotations(run: _Run) -> list[str]:
    """GitHub Actions annotations: each failed expectation at its scenario line (an error),
    each program stop at the scenario (a notice: a scenario may provoke one)."""
    file = str(run.scenario.file)
    lines = [github_command("error", str(f), file=file, line=f.line, title="expectation failed")
             for f in run.result.failures]
    lines += [github_command("notice", f"at {s.at_ms:g} ms: program stopped: {s.reason}",
                             file=file, title="program stopped") for s in run.result.stops]
    return lines


def _summary(run: _Run) -> str:
    r = run.result
    failed = len(r.failures)
    return (
        f"{r.checked} expectation{'s' if r.checked != 1 else ''}, {failed} failed; "
        f"{r.end_ms / 1000:g} s of master time in {run.seconds:.2f} s"
    )


def _as_json(run: _Run) -> dict:
    r = run.result
    return {
        "scenario": run.scenario.file,
        "passed": r.passed,
        "checked": r.checked,
        "failures": [
            {"line": f.line, "at_ms": f.step.at_ms, "operand": str(f.operand),
             "expected": f.expected, "got": f.got}
            for f in r.failures
        ],
        "stops": [{"at_ms": s.at_ms, "reason": s.reason} for s in r.stops],
        "end_ms": r.end_ms,
        "wall_s": round(run.seconds, 3),
    }


@click.command()
@click.argument("program", required=False, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--scenario", "scenario_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Scenario file (TOML): inputs over time and expected outputs.")
@click.option("--duration", help="Master time to run, e.g. 10s, 250ms, 1h (default: until "
              "the scenario's last step; 10s without a scenario).")
@click.option("--vcd", type=click.Path(dir_okay=False, path_type=Path),
              help="Write a value change dump (GTKWave).")
@click.option("--csv", "csv_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Write the trace as CSV.")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path),
              help="Write a timing diagram (PNG; needs matplotlib).")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@click.option("--lib", multiple=True, type=click.Path(file_okay=False),
              help="Also look for function-block files here.")
def sim(
    program: Path | None, scenario_path: Path | None, duration: str | None, vcd: Path | None,
    csv_path: Path | None, plot: Path | None, as_json: bool, lib: tuple[str, ...],
) -> None:
    """Run PROGRAM on a fresh emulated master in virtual time.

    With --scenario, apply its inputs and check its expectations; each failed expectation
    is printed as 'scenario.toml:LINE: at 250 ms: Q 17.3 expected 1, got 0'. Program
    stops (cycle time-out, configuration error) are reported with their time. PROGRAM
    may be left out when the scenario names it.

    Exit status: 0 all expectations hold, 1 one failed, 2 bad input.
    """
    ctx = click.get_current_context()
    try:
        duration_ms = parse_duration(duration) if duration else None
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--duration") from None
    try:
        run = _run(program, scenario_path, duration_ms=duration_ms,
                   trace=bool(vcd or csv_path or plot), lib=lib)
    except _Invalid:
        ctx.exit(int(ExitCode.USAGE))
    trace = run.result.trace
    if trace is not None:
        inputs = [run.program, *([scenario_path] if scenario_path else [])]
        if vcd:
            write_output(vcd, to_vcd(trace), inputs=inputs)
        if csv_path:
            write_output(csv_path, to_csv(trace), inputs=inputs)
        if plot:
            refuse_inputs(plot, inputs)
            write_plot(trace, plot, title=f"{run.program.name}: {run.scenario.file}")
    if as_json:
        click.echo(json.dumps(_as_json(run), indent=2))
    else:
        for line in _report_lines(run):
            click.echo(line)
        click.echo(_summary(run))
    ctx.exit(int(ExitCode.OK if run.result.passed else ExitCode.FAILED))


def _find(paths: tuple[Path, ...]) -> list[Path]:
    found: list[Path] = []
    for path in paths or (Path(),):
        if path.is_dir():
            found.extend(sorted(p for p in path.rglob(f"*{SUFFIX}") if p.is_file()))
        elif path.is_file():
            found.append(path)
        else:
            raise UserError(f"{path}: no such file or directory")
    return found


def _junit(results: list[tuple[Path, _Run | None, str]], path: Path) -> None:
    suite = ElementTree.Element(
        "testsuite", name="asictl", tests=str(len(results)),
        failures=str(sum(1 for _, run, _ in results if run and not run.result.passed)),
        errors=str(sum(1 for _, run, _ in results if run is None)),
    )
    for scenario, run, message in results:
        case = ElementTree.SubElement(
            suite, "testcase", classname="asictl.scenario", name=str(scenario),
            time=f"{run.seconds:.3f}" if run else "0",
        )
        if run is None:
            ElementTree.SubElement(case, "error", message=message or "invalid input")
        elif not run.result.passed:
            failure = ElementTree.SubElement(case, "failure", message=_summary(run))
            failure.text = "\n".join(_report_lines(run))
    ElementTree.indent(suite)
    inputs = [p for scenario, run, _ in results for p in (scenario, run and run.program) if p]
    write_output(path, ElementTree.tostring(suite, encoding="unicode", xml_declaration=True)
                 + "\n", inputs=inputs)


@click.command()
@click.argument("paths", nargs=-1, type=click.Path(path_type=Path))
@click.option("--junit", type=click.Path(dir_okay=False, path_type=Path),
              help="Also write the results as JUnit XML for CI systems.")
@click.option("--lib", multiple=True, type=click.Path(file_okay=False),
              help="Also look for function-block files here.")
@click.option("--format", "fmt", type=click.Choice(["text", "github"]), default="text",
              show_default=True, help="github: also a GitHub Actions annotation at the "
              "scenario line of each failed expectation.")
def test(
    paths: tuple[Path, ...], junit: Path | None, lib: tuple[str, ...], fmt: str
) -> None:
    """Run every *.scenario.toml under PATHs (default: the current directory).

    A scenario without a 'program' line tests the program of the same name beside it
    (blink.scenario.toml tests blink.asi). Prints one line per scenario and a summary
    'N passed, M failed'.

    Exit status: 0 all passed, 1 a scenario failed, 2 a scenario or program is invalid.
    """
    ctx = click.get_current_context()
    scenarios = _find(paths)
    if not scenarios:
        raise UserError(f"no {SUFFIX} files found")
    results: list[tuple[Path, _Run | None, str]] = []
    for path in scenarios:
        try:
            run = _run(None, path, duration_ms=None, trace=False, lib=lib)
        except (_Invalid, UserError) as exc:
            message = str(exc) if isinstance(exc, UserError) else "invalid scenario or program"
            click.echo(f"ERROR {path}: {message}")
            if fmt == "github":
                click.echo(github_command("error", message, file=str(path), title="asictl test"))
            results.append((path, None, message))
            continue
        results.append((path, run, ""))
        click.echo(f"{'PASS' if run.result.passed else 'FAIL'} {path}: {_summary(run)}")
        for line in _report_lines(run):
            click.echo(f"    {line}")
        if fmt == "github":
            for annotation in _annotations(run):
                click.echo(annotation)
    passed = sum(1 for _, run, _ in results if run and run.result.passed)
    errors = sum(1 for _, run, _ in results if run is None)
    click.echo(f"{passed} passed, {len(results) - passed} failed")
    if junit:
        _junit(results, junit)
    if errors:
        ctx.exit(int(ExitCode.USAGE))
    ctx.exit(int(ExitCode.OK if passed == len(results) else ExitCode.FAILED))
