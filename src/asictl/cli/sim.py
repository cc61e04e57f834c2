"""``asictl sim`` and ``asictl test``: programs against scenarios, in virtual time."""

from __future__ import annotations

import concurrent.futures
import json
import sys
import time
from collections.abc import Iterator
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from xml.etree import ElementTree

import click

from asictl.cli import junit
from asictl.cli.options import (
    Duration,
    below_bar,
    coverage_fail_under_option,
    lib_option,
    shard_option,
    take_shard,
)
from asictl.diagnostics import github_command
from asictl.errors import ExitCode, UserError
from asictl.files import refuse_inputs, write_output
from asictl.observe.coverage import Coverage
from asictl.observe.iltrace import to_csv as rows_csv
from asictl.readers.shard import Shard
from asictl.readers.units import format_duration
from asictl.sim import SUFFIX
from asictl.sim.coverage import FORMATS, format_for, missing, percent, render
from asictl.sim.coverage import summary as coverage_summary
from asictl.sim.engine import line_map_of
from asictl.sim.scenario import MAX_TIME_MS
from asictl.sim.session import (
    WORKER_DIED,
    Invalid,
    Outcome,
    as_json,
    default_jobs,
    events,
    final_lines,
    find_scenarios,
    prepare,
    run_file,
    scenario_for,
    simulate,
    summary,
)
from asictl.sim.trace import to_csv, to_vcd, write_plot


@click.command()
@click.argument("program", required=False, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--scenario", "scenario_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Scenario file (TOML): inputs over time and expected outputs "
              "(default: PROGRAM's NAME.scenario.toml beside it, if there is one).")
@click.option("--no-scenario", is_flag=True,
              help="Do not use the scenario beside the program.")
@click.option("--set", "sets", multiple=True, metavar='"OPERAND=VALUE"',
              help='Set an input or flag at time 0, e.g. --set "I 1.0=1" (repeatable).')
@click.option("--duration", type=Duration(limit_ms=MAX_TIME_MS),
              help="Master time to run, e.g. 10s, 250ms, 1h (default: until "
              "the scenario's last step; 10s without a scenario; at most 24h).")
@click.option("--allow-partial", is_flag=True,
              help="Allow a --duration that ends before the scenario's last step.")
@click.option("--vcd", type=click.Path(dir_okay=False, path_type=Path),
              help="Write a value change dump (GTKWave).")
@click.option("--csv", "csv_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Write the trace as CSV.")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path),
              help="Write a timing diagram (PNG; needs matplotlib).")
@click.option("--signals", help='Trace only these lanes: comma-separated operands, symbols '
              'or shell patterns, e.g. "Q 2.*,CV 0".')
@click.option("--trace-il", "trace_il", type=click.Path(dir_okay=False, path_type=Path),
              help="Write one CSV row per executed IL line: time, line, RLO, ACCU1, ACCU2.")
@click.option("--from", "from_", type=Duration(limit_ms=MAX_TIME_MS), metavar="TIME",
              help="Traces start here (e.g. 250ms, 2s; default 0).")
@click.option("--to", type=Duration(limit_ms=MAX_TIME_MS), metavar="TIME",
              help="Traces end here (default: the end of the run).")
@click.option("--json", "as_json_", is_flag=True, help="Print the result as JSON.")
@lib_option
def sim(
    program: Path | None, scenario_path: Path | None, no_scenario: bool, sets: tuple[str, ...],
    duration: float | None, allow_partial: bool, vcd: Path | None, csv_path: Path | None,
    plot: Path | None, signals: str | None, trace_il: Path | None, from_: float | None,
    to: float | None, as_json_: bool, lib: tuple[str, ...],
) -> None:
    """Run PROGRAM on a fresh emulated master in virtual time.

    With a scenario, apply its inputs and check its expectations; each failed expectation
    is printed as 'scenario.toml:LINE: at 250 ms: Q 17.3 expected 1, got 0'. Program
    stops (cycle time-out, configuration error) are reported with their time and IL
    line. PROGRAM may be left out when the scenario names it.

    Exit status: 0 all expectations hold, 1 one failed or the program has errors, 2 bad
    input.

    \b
    Examples:
      asictl sim demos/blink.asi
      asictl sim demos/timer.asi --vcd timer.vcd --csv timer.csv
      asictl sim demos/ondelay.asi --no-scenario --set "I 1.0=1" --duration 5s
    """
    ctx = click.get_current_context()
    duration_ms, start, end = duration, from_ or 0.0, to
    if end is not None and end < start:
        raise click.BadParameter("--to comes before --from", param_hint="--to")
    if scenario_path is None and program is not None and not no_scenario:
        beside = scenario_for(program)
        if beside.is_file():
            scenario_path = beside
            click.echo(f"asictl: note: checking {beside}", err=True)
    try:
        prepared = prepare(program, scenario_path, lib=lib, sets=sets, duration_ms=duration_ms,
                           allow_partial=allow_partial)
        click.echo(prepared.notes, nl=False, err=True)
        progress = _SimProgress()
        try:
            run = simulate(
                prepared, trace=bool(vcd or csv_path or plot),
                signals=[s.strip() for s in signals.split(",") if s.strip()] if signals
                else None,
                il_trace=trace_il is not None, window=(start, end),
                progress=progress if progress.enabled else None,
            )
        finally:
            progress.clear()
    except Invalid as exc:
        click.echo(exc.text, nl=False, err=True)
        ctx.exit(int(exc.exit_code))
    click.echo(run.note, nl=False, err=True)
    #: the files this run read: no output may replace one of them
    inputs = [run.prepared.program, *([scenario_path] if scenario_path else [])]
    trace = run.result.trace
    if trace is not None:
        shown = trace.window(start, end) if (start or end is not None) else trace
        if not shown.signals:
            click.echo(f"asictl: warning: --signals '{signals}' matches no lane", err=True)
        if vcd:
            write_output(vcd, to_vcd(shown), inputs=inputs)
        if csv_path:
            write_output(csv_path, to_csv(shown), inputs=inputs)
        if plot:
            refuse_inputs(plot, inputs)
            write_plot(shown, plot, title=f"{run.prepared.program.name}: {run.scenario.file}")
    if trace_il is not None:
        if not line_map_of(run.prepared.build):
            click.echo(f"asictl: warning: {run.prepared.program}: the image has no line map "
                       "(image format version 1): --trace-il has nothing to show", err=True)
        write_output(trace_il, rows_csv(run.result.il_rows), inputs=inputs)
    if as_json_:
        click.echo(json.dumps(as_json(run), indent=2, allow_nan=False))
    else:
        for line in events(run):
            click.echo(line)
        if not run.result.checked:
            for line in final_lines(run):
                click.echo(line)
        click.echo(summary(run))
    ctx.exit(int(ExitCode.OK if run.result.passed else ExitCode.FAILED))


# ---------------------------------------------------------------------- asictl test


def _junit(outcomes: list[Outcome], path: Path, inputs: list[Path]) -> None:
    cases = []
    for outcome in outcomes:
        case = ElementTree.Element(
            "testcase", classname="asictl.scenario", name=outcome.path,
            time=f"{outcome.seconds:.3f}",
        )
        if outcome.status == "ERROR":
            error = ElementTree.SubElement(case, "error", message=outcome.message)
            error.text = outcome.stderr or None
        elif outcome.status == "FAIL":
            failure = ElementTree.SubElement(case, "failure", message=outcome.summary)
            failure.text = "\n".join(outcome.events)
        cases.append(case)
    write_output(path, junit.suite(cases), inputs=inputs)


class _StatusLine:
    """A line on a terminal's standard error, to be erased before other output, which
    would otherwise go on from its end."""

    shown = False

    def clear(self) -> None:
        if self.shown:
            sys.stderr.write("\r\x1b[K")
            sys.stderr.flush()
            self.shown = False


class _SimProgress(_StatusLine):
    """A long simulation's progress on a terminal's standard error: master time done of
    the run's, shown once the run has taken a second, at most five times a second."""

    def __init__(self) -> None:
        self.enabled = sys.stderr.isatty()
        self.begun = time.monotonic()
        self.last = 0.0

    def __call__(self, now_ms: float, end_ms: float) -> None:
        wall = time.monotonic()
        if wall - self.begun < 1.0 or wall - self.last < 0.2:
            return
        self.last = wall
        sys.stderr.write(f"\r\x1b[K[sim] {format_duration(now_ms)} of {format_duration(end_ms)} "
                         f"master time ({100 * now_ms / end_ms if end_ms else 100:.0f}%)")
        sys.stderr.flush()
        self.shown = True


class _Progress(_StatusLine):
    """One line on a terminal's standard error: scenarios done, failures so far."""

    def __init__(self, total: int) -> None:
        self.total = total
        self.enabled = total > 1 and sys.stderr.isatty()
        self.done = self.failed = 0

    def update(self, outcome: Outcome) -> None:
        self.done += 1
        self.failed += outcome.status != "PASS"
        if self.enabled:
            sys.stderr.write(f"\r\x1b[K[{self.done}/{self.total}] {self.failed} failed")
            sys.stderr.flush()
            self.shown = True


def _json(outcome: Outcome) -> dict[str, object]:
    """One scenario of ``test --format json``."""
    return {
        "path": outcome.path, "status": outcome.status, "program": outcome.program or None,
        "summary": outcome.summary, "message": outcome.message or None,
        "events": outcome.events, "stops": outcome.stops,
        "failures": [{"line": line, "text": text} for line, text in outcome.failures],
        "seconds": round(outcome.seconds, 3),
    }


def _print(outcome: Outcome, progress: _Progress, fmt: str) -> None:
    progress.clear()
    if outcome.stderr:
        click.echo(outcome.stderr, nl=False, err=True)
    if outcome.status == "ERROR":
        click.echo(f"ERROR {outcome.path}: {outcome.message}")
    else:
        click.echo(f"{outcome.status} {outcome.path}: {outcome.summary}")
        for line in outcome.events:
            click.echo(f"    {line}")
    if fmt == "github":
        for annotation in _annotations(outcome):
            click.echo(annotation)


def _annotations(outcome: Outcome) -> list[str]:
    """GitHub Actions annotations: each failed expectation at its scenario line (an error),
    each program stop at the scenario (a notice: a scenario may provoke one), an invalid
    scenario at its file."""
    if outcome.status == "ERROR":
        return [github_command("error", outcome.message, file=outcome.path,
                               title="asictl test")]
    lines = [github_command("error", text, file=outcome.path, line=line,
                            title="expectation failed") for line, text in outcome.failures]
    lines += [github_command("notice", text, file=outcome.path, title="program stopped")
              for text in outcome.stops]
    return lines


def _outcomes(
    paths: list[str], lib: tuple[str, ...], jobs: int, coverage: bool = False
) -> Iterator[Outcome]:
    """Each scenario's outcome in the order of ``paths`` as soon as it and every one
    before it are done; worker processes when ``jobs`` > 1.

    A worker that dies (the OOM killer, a signal) breaks the whole pool, and the pool
    cannot say which scenario it was running: every scenario not done by then runs
    again, each in a worker of its own, so that the one whose worker dies again is an
    ERROR row and the others still have their results."""
    if jobs <= 1 or len(paths) <= 1:
        for path in paths:
            yield run_file(path, lib, coverage)
        return
    with concurrent.futures.ProcessPoolExecutor(max_workers=min(jobs, len(paths))) as pool:
        futures = [pool.submit(run_file, path, lib, coverage) for path in paths]
        done = 0
        try:
            for future in futures:
                yield future.result()
                done += 1
            return
        except BrokenProcessPool:
            pass
    with concurrent.futures.ThreadPoolExecutor(max_workers=jobs) as threads:
        again = [_kept(future) or threads.submit(_alone, path, lib, coverage)
                 for path, future in zip(paths[done:], futures[done:], strict=True)]
        for future in again:
            yield future.result()


def _kept(future: concurrent.futures.Future[Outcome]) -> concurrent.futures.Future[Outcome] | None:
    """A scenario's future when it finished before its pool broke."""
    if future.done() and not future.cancelled() and future.exception() is None:
        return future
    return None


def _alone(path: str, lib: tuple[str, ...], coverage: bool) -> Outcome:
    """One scenario in a worker process of its own; its death is its ERROR row."""
    with concurrent.futures.ProcessPoolExecutor(max_workers=1) as pool:
        try:
            return pool.submit(run_file, path, lib, coverage).result()
        except BrokenProcessPool:
            return Outcome(path, "ERROR", died=True, message=WORKER_DIED)


@click.command()
@click.argument("paths", nargs=-1, type=click.Path(path_type=Path))
@click.option("--junit", "junit_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Also write the results as JUnit XML for CI systems.")
@click.option("-j", "--jobs", type=click.IntRange(min=1), default=None,
              help="Scenarios run at once, in worker processes (default: the number of "
              "cores; 1 runs them one after the other here).")
@shard_option("scenario files")
@lib_option
@click.option("--format", "fmt", type=click.Choice(["text", "github", "json"]), default="text",
              show_default=True, help="github: also a GitHub Actions annotation at the "
              "scenario line of each failed expectation; json: one JSON document, "
              '{"scenarios": [...], "summary": {...}}, each scenario written as it is done.')
@click.option("--coverage", "coverage_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Write the IL coverage of all scenarios (lines, branches, conditions).")
@click.option("--coverage-format", type=click.Choice(FORMATS), default=None,
              help="Format of --coverage (default: by its suffix, .json json, .info or "
              ".lcov lcov, else cobertura; sonarqube: its generic coverage XML).")
@coverage_fail_under_option
def test(paths: tuple[Path, ...], junit_path: Path | None, jobs: int | None,
         shard: Shard | None, lib: tuple[str, ...], fmt: str, coverage_path: Path | None,
         coverage_format: str | None, coverage_fail_under: float | None) -> None:
    """Run every *.scenario.toml under PATHs (default: the current directory).

    A scenario without a 'program' line tests the program of the same name beside it
    (blink.scenario.toml tests blink.asi). Prints one line per scenario, in a stable
    order whatever -j is, each as soon as it and the ones before it are done, and a
    summary 'N passed, M failed'; --format json writes the same as one JSON document.

    With --coverage (or --coverage-fail-under) the simulator also records which IL
    lines ran, which way each JC and BEC went and which values each bit operand of a
    condition had, over all scenarios, and prints a line 'coverage: lines 93%
    (112/120), branches 80% (8/10), conditions 75% (30/40)' (docs/testing.md).

    pytest runs the same scenarios ('pytest DIR', with --asictl-coverage FILE for the
    coverage), together with Python tests that use asictl.testing (docs/testing.md).

    Exit status: 0 all passed, 1 a scenario failed, a program has errors (or a worker
    process died, an ERROR row, or coverage is below --coverage-fail-under), 2 a scenario
    is invalid.

    \b
    Examples:
      asictl test demos
      asictl test demos/blink.scenario.toml --coverage coverage.xml --coverage-fail-under 80
      asictl test demos --shard 1/2 --junit junit-1.xml --coverage coverage-1.json
    """
    ctx = click.get_current_context()
    scenarios = [str(p) for p in find_scenarios(paths)]
    if not scenarios:
        raise UserError(f"no {SUFFIX} files found")
    scenarios = take_shard(scenarios, scenarios, shard, "scenario files")
    progress = _Progress(len(scenarios))
    outcomes: list[Outcome] = []
    collect = coverage_path is not None or coverage_fail_under is not None
    if fmt == "json":
        click.echo('{"scenarios": [')
    for outcome in _outcomes(scenarios, lib, jobs or default_jobs(), collect):
        outcomes.append(outcome)
        if fmt == "json":
            progress.clear()
            click.echo(("  " if len(outcomes) == 1 else ", ") + json.dumps(_json(outcome)))
        else:
            _print(outcome, progress, fmt)
        progress.update(outcome)
    progress.clear()
    passed = sum(1 for o in outcomes if o.status == "PASS")
    if fmt == "json":
        errors = sum(1 for o in outcomes if o.status == "ERROR")
        summary = {"total": len(outcomes), "passed": passed,
                   "failed": len(outcomes) - passed - errors, "errors": errors}
        click.echo(f'], "summary": {json.dumps(summary)}}}')
    else:
        click.echo(f"{passed} passed, {len(outcomes) - passed} failed")
    read = [Path(p) for p in (*scenarios, *(o.program for o in outcomes if o.program))]
    if junit_path:
        _junit(outcomes, junit_path, read)
    below = False
    if collect:
        coverage = Coverage()
        for outcome in outcomes:
            if outcome.coverage is not None:
                coverage.merge(outcome.coverage)
        # after a JSON document, on standard error: standard output stays one document
        click.echo(coverage_summary(coverage), err=fmt == "json")
        names = {str(Path(o.program).resolve()): o.names for o in outcomes if o.program}
        for row in missing(coverage, names):
            click.echo("  " + row, err=fmt == "json")
        if coverage_path is not None:
            text = render(coverage, format_for(str(coverage_path), coverage_format))
            write_output(coverage_path, text, inputs=[*read, *coverage.files_read()])
        below = below_bar("line coverage", percent(*coverage.totals()["lines"]),
                          coverage_fail_under, "--coverage-fail-under", 2)
    if any(o.bug for o in outcomes):
        ctx.exit(int(ExitCode.BUG))
    if any(o.status == "ERROR" and not o.died for o in outcomes):
        ctx.exit(max(o.exit_code for o in outcomes if o.status == "ERROR" and not o.died))
    ctx.exit(int(ExitCode.OK if passed == len(outcomes) and not below else ExitCode.FAILED))
