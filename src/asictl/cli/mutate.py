"""``asictl mutate``: mutation testing of programs against their scenarios."""

from __future__ import annotations

import dataclasses
import json
import os
from collections import defaultdict
from pathlib import Path, PurePath

import click

import asictl.quality.mutate as mutation
from asictl.cli.options import (
    Duration,
    below_bar,
    lib_option,
    min_score_option,
    shard_option,
    take_shard,
)
from asictl.diagnostics import DiagnosticError, render_text
from asictl.errors import ExitCode, UserError
from asictl.observe.operands import parse_operand
from asictl.observe.symbols import load_symbols
from asictl.quality.cache import Cache, default_directory
from asictl.quality.mutate import PROVE_HINT, Result, Target, mutants_of, run_all, score
from asictl.readers.shard import Shard
from asictl.sim import SUFFIX
from asictl.sim.engine import variables_of
from asictl.sim.session import (
    Invalid,
    Prepared,
    default_jobs,
    find_scenarios,
    prepare,
    simulate,
)
from asictl.source import read_source


def _shown(path: str) -> str:
    try:
        return PurePath(os.path.relpath(path)).as_posix()
    except ValueError:  # another drive
        return path


def _named_by(prepared: Prepared, symbols: Path) -> Prepared:
    """``prepared`` with the operands of its notes named by the table ``symbols`` (each
    operand checked against its program, variables included) instead of the one beside
    the program."""
    assert prepared.build.image is not None
    variables = variables_of(prepared.build.image.pmap)

    def check(text: str) -> str:
        return str(parse_operand(text, variables))

    try:
        table = load_symbols(symbols, check)
    except DiagnosticError as exc:
        rendered = render_text(exc.diagnostics, {str(symbols): read_source(symbols).text})
        raise UserError(f"--symbols {symbols}: the table has errors\n{rendered.rstrip()}"
                        ) from None
    return dataclasses.replace(prepared, symbols=table)


def _targets(paths: tuple[Path, ...], lib: tuple[str, ...], shard: Shard | None,
             symbols: Path | None = None) -> list[Target]:
    """The programs the scenarios under ``paths`` test (those of ``shard``), each with its
    scenarios, in the order of their paths; every scenario must pass on the original
    program (else no mutant can be judged). ``symbols`` names the operands of the notes
    (default: the table beside each program)."""
    by_program: dict[Path, list[tuple[Path, Prepared]]] = defaultdict(list)
    scenarios = find_scenarios(paths)
    if not scenarios:
        raise UserError(f"no {SUFFIX} files found")
    for scenario in scenarios:
        try:
            prepared = prepare(None, scenario, lib=lib)
        except Invalid as exc:
            raise UserError(f"{scenario}: {exc.message}\n{exc.text.rstrip()}",
                            exc.exit_code) from None
        if symbols is not None:
            prepared = _named_by(prepared, symbols)
        by_program[prepared.program.resolve()].append((scenario, prepared))
    programs = sorted(by_program, key=lambda key: Path(_shown(str(key))))
    targets = []
    for key in take_shard(programs, programs, shard, "programs"):
        target = Target(Path(_shown(str(key))), [])
        for scenario, prepared in by_program[key]:
            run = simulate(prepared, coverage=True, coverage_counts=False)
            if not run.result.passed:
                raise UserError(
                    f"{scenario} fails on the unchanged program: mutation testing needs "
                    f"passing scenarios (see 'asictl test {scenario}')", ExitCode.FAILED,
                )
            target.scenarios.append(prepared)
            target.seconds += run.seconds
            if run.result.coverage is not None:
                target.reached |= run.result.coverage.reached()
        program = target.scenarios[0].build.program
        assert program is not None
        target.mutants = mutants_of(program)
        targets.append(target)
    return targets


def _line(result: Result) -> str:
    m = result.mutant
    detail = f" ({result.detail})" if result.detail else ""
    return f"{_shown(m.file)}:{m.line}:{m.column}: {result.verdict}: {m.change}{detail}"


def _summary(results: list[Result]) -> str:
    killed, counted = score(r.verdict for r in results)
    counts = {v: sum(1 for r in results if r.verdict == v)
              for v in ("killed", "timeout", "survived", "died", "equivalent", "invalid")}
    share = percent_killed(killed, counted)
    parts = ", ".join(f"{n} {v}" for v, n in counts.items() if n)
    return f"{len(results)} mutants: {parts or 'none'}; score {share:.1f}% ({killed}/{counted})"


@click.command()
@click.argument("paths", nargs=-1, type=click.Path(path_type=Path))
@click.option("-j", "--jobs", type=click.IntRange(min=1), default=None,
              help="Mutants run at once, each in a worker process (default: the number "
              "of cores).")
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text",
              show_default=True, help="json: one object with every mutant and the score.")
@min_score_option
@click.option("--timeout", "timeout_ms", type=Duration(positive=True),
              metavar="TIME", help="Time limit of one mutant (default: 10 s plus five "
              "times what its program's scenarios take unchanged).")
@click.option("--proof-timeout", "prove_ms", type=Duration(positive=True),
              default=f"{mutation.PROVE_SECONDS:g}s", show_default=True, metavar="TIME",
              help="Time the prover (the prove extra) may spend on one surviving mutant's "
              "proof of equivalence; out of time, the mutant stays a survivor.")
@click.option("--cache", "cache_dir", type=click.Path(file_okay=False, path_type=Path),
              metavar="DIR", help="Keep the verdicts in DIR and take those whose program, "
              "scenarios, limits and asictl are unchanged from there (default: "
              "$XDG_CACHE_HOME/asictl/mutate, or ~/.cache/asictl/mutate).")
@click.option("--no-cache", is_flag=True, help="Judge every mutant afresh and keep nothing.")
@click.option("--symbols", type=click.Path(dir_okay=False, path_type=Path),
              help="The symbol table that names operands in the notes of killed mutants "
              "and survivors [default: NAME.symbols.toml beside each NAME.asi].")
@shard_option("programs")
@lib_option
def mutate(paths: tuple[Path, ...], jobs: int | None, fmt: str, min_score: float | None,
           timeout_ms: float | None, prove_ms: float, cache_dir: Path | None,
           no_cache: bool, symbols: Path | None, shard: Shard | None,
           lib: tuple[str, ...]) -> None:
    """Mutation testing: change each program the scenarios under PATHs test (default:
    the current directory) in one place at a time, and run its scenarios.

    The changes: A<->AN, O<->ON, S<->R, an assignment removed, JC made unconditional
    or removed, BEC removed, L KT / L KC one step off, a comparison negated, a bit
    operand moved to its neighbour, L KB one off, a [GATING] term negated. A mutant a
    scenario fails on is killed (one that runs past its time limit: timeout, killed
    too); one all pass on survived: a scenario is missing (docs/testing.md). Prints
    each mutant as FILE:LINE:COL: VERDICT: CHANGE and the score, killed / (mutants -
    equivalent - invalid).

    A verdict is kept (--cache), and a second run takes it from there unless the
    program, its scenarios, the time limits or asictl have changed: after a change to
    one program only its mutants run again.

    Exit status: 0 done (and the score reaches --min-score), 1 below --min-score, a
    scenario fails on the unchanged program or a program has errors, 2 bad input.

    Notes name operands as the program's symbol table does (NAME.symbols.toml beside
    NAME.asi, or --symbols FILE for every program): Q 31.0 (Lamp).

    \b
    Examples:
      asictl mutate demos/blink.scenario.toml --min-score 80
      echo 'Lamp = "Q 31.0"' > l.toml; asictl mutate demos/blink.scenario.toml --symbols l.toml
    """
    ctx = click.get_current_context()
    if no_cache and cache_dir is not None:
        raise click.UsageError("--cache and --no-cache exclude each other")
    directory = cache_dir or default_directory()
    cache = None if no_cache or directory is None else Cache(directory)
    targets = _targets(paths, lib, shard, symbols)
    order = {id(m): i for i, m in enumerate(m for t in targets for m in t.mutants)}
    finished: dict[int, Result] = {}
    shown = 0

    def done(result: Result) -> None:
        """Text lines in the mutants' order, each as soon as it and those before it are."""
        nonlocal shown
        finished[order[id(result.mutant)]] = result
        while fmt == "text" and shown in finished:
            click.echo(_line(finished[shown]))
            shown += 1

    results = run_all(targets, jobs=jobs or default_jobs(),
                      timeout_s=None if timeout_ms is None else timeout_ms / 1000,
                      prove_s=prove_ms / 1000, done=done, cache=cache)
    checked = mutation.prove_available()
    report = json_report([
        {"file": _shown(r.mutant.file), "line": r.mutant.line, "column": r.mutant.column,
         "change": r.mutant.change, "verdict": r.verdict, "detail": r.detail,
         "seconds": round(r.seconds, 3), "cached": r.cached}
        for r in results
    ], checked)
    share = percent_killed(*score(r.verdict for r in results))
    if fmt == "json":
        click.echo(json.dumps(report, indent=2))
    else:
        click.echo(_summary(results))
        if cache is not None:
            click.echo(f"note: {report['from_cache']} of {len(results)} verdicts from the cache "
                       f"({cache.directory})")
        if not checked and any(r.verdict == "survived" for r in results):
            click.echo(f"note: {PROVE_HINT}")
    for problem in cache.problems if cache is not None else ():
        click.echo(f"asictl: warning: {problem}", err=True)
    below = below_bar("mutation score", share, min_score, "--min-score", 1)
    ctx.exit(int(ExitCode.FAILED if below else ExitCode.OK))


def json_report(mutants: list[dict[str, object]], checked: bool) -> dict[str, object]:
    """``mutate --format json``: every mutant, the score they make, and how many of their
    verdicts came from the cache (``report merge`` puts the shards' mutants together
    with this too)."""
    killed, counted = score(str(m["verdict"]) for m in mutants)
    return {"mutants": mutants, "killed": killed, "counted": counted,
            "score": round(percent_killed(killed, counted), 2), "equivalence_checked": checked,
            "from_cache": sum(1 for m in mutants if m.get("cached") is True)}


def percent_killed(killed: int, counted: int) -> float:
    """The score in percent, killed of counted; no mutant to count is all of them."""
    return 100.0 * killed / counted if counted else 100.0
