"""``asictl prove``: decide a program's properties for every input sequence."""

from __future__ import annotations

import json
from pathlib import Path

import click

from asictl.cli.options import CycleCount, Duration, lib_option, shard_option, take_shard
from asictl.errors import ExitCode, missing_extra
from asictl.prove import DEPTH, MAX_DEPTH
from asictl.readers.shard import Shard
from asictl.readers.units import Cycles, format_duration

_HELP_FORMAT = click.Choice(["text", "json"])


def _files(paths: tuple[Path, ...], properties: Path | None) -> list[tuple[Path, Path | None]]:
    """(properties file, program or None for the one it names) for each argument."""
    from asictl.prove.props import SUFFIX, properties_for

    if properties is not None:
        return [(properties, p) for p in paths] or [(properties, None)]
    pairs: list[tuple[Path, Path | None]] = []
    for path in paths or tuple(sorted(Path().glob(f"*{SUFFIX}"))):
        if path.name.endswith(SUFFIX):
            pairs.append((path, None))
        else:
            beside = properties_for(path)
            if not beside.is_file():
                raise click.UsageError(f"{path}: no properties file {beside} beside it "
                                       "(or give one with --properties)")
            pairs.append((beside, path))
    if not pairs:
        raise click.UsageError(f"no *{SUFFIX} here: name a program or a properties file")
    return pairs


def _operands(outcome: object, symbols: object) -> list[tuple[str, str, int]]:
    """(operand, as named, value): the property's operands after the last cycle of a
    counterexample or witness (a response's: the answer's), each named as the symbol
    table names it (``Q 2.0 (Forward)``)."""
    from asictl.observe.condition import refs
    from asictl.observe.names import named
    from asictl.observe.symbols import SymbolTable
    from asictl.prove.engine import Outcome

    assert isinstance(outcome, Outcome) and isinstance(symbols, SymbolTable)
    prop = outcome.prop
    expr = prop.expr if prop.then is None else prop.then
    found = {str(ref.operand): outcome.values[ref.text]
             for ref in refs(expr) if ref.text in outcome.values}
    return [(text, named(text, symbols), value) for text, value in found.items()]


def _line(outcome: object, written: Path | None, symbols: object) -> str:
    from asictl.prove.engine import Outcome, Verdict

    assert isinstance(outcome, Outcome)
    verdict, cycles = outcome.verdict, outcome.depth + 1
    plural = "s" if cycles != 1 else ""
    if verdict is Verdict.PROVED:
        how = ("k-induction" if outcome.depth else "invariant") + f", depth {outcome.depth}"
        if outcome.trivially:
            how = f"trivially: {outcome.trivially}"
        text = f"proved       {outcome.prop.name} ({how})"
    elif verdict is Verdict.UNREACHABLE:
        how = (f"trivially: {outcome.trivially}" if outcome.trivially
               else f"depth {outcome.depth}")
        text = f"unreachable  {outcome.prop.name} ({how})"
    elif verdict in (Verdict.REFUTED, Verdict.REACHED):
        text = f"{verdict.value:<12} {outcome.prop.name} in cycle {cycles}"
        values = ", ".join(f"{shown} = {value}"
                           for _, shown, value in _operands(outcome, symbols))
        if values:
            text += f" with {values}"
        if written is not None:
            text += f": {written}"
    elif verdict is Verdict.BOUNDED:
        shown = "not reached" if outcome.prop.kind.value == "reachable" else "holds"
        text = f"{shown} up to {cycles} cycle{plural}: {outcome.prop.name} (no proof)"
    else:
        text = f"unknown      {outcome.prop.name}"
    text += f" [{format_duration(outcome.seconds * 1000)}]"
    if outcome.note:
        text += f"\n    note: {outcome.note}"
    return text


@click.command("prove")
@click.argument("files", nargs=-1, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--properties", type=click.Path(dir_okay=False, path_type=Path),
              help="The properties file [default: NAME.props.toml beside NAME.asi].")
@click.option("--depth", type=CycleCount(MAX_DEPTH),
              help="Cycles the search for counterexamples and the induction go to "
              f"[default: {DEPTH}]; given, it bounds the runs of held inputs too "
              "[default: the timers' presets times the counters'].")
@click.option("--timeout", type=Duration(limit_ms=86_400_000, positive=True), default="30s",
              show_default=True,
              help="Wall-clock time for each property, the first's from the start (30s, 5min).")
@click.option("--unroll", type=click.IntRange(1, 1000), default=8, show_default=True,
              help="How often a backward jump is followed in one cycle.")
@click.option("--format", "fmt", type=_HELP_FORMAT, default="text", show_default=True)
@click.option("--counterexamples", type=click.Path(file_okay=False, path_type=Path),
              help="Where to write counterexamples and witnesses [default: beside the "
              "properties file].")
@click.option("--force", is_flag=True,
              help="Replace files in the way that asictl prove did not write.")
@click.option("--symbols", type=click.Path(dir_okay=False, path_type=Path),
              help="The symbol table that names operands in properties and verdicts "
              "[default: NAME.symbols.toml beside NAME.asi].")
@shard_option("files")
@lib_option
def prove(files: tuple[Path, ...], properties: Path | None, depth: Cycles | None, timeout: float,
          unroll: int, fmt: str, counterexamples: Path | None, force: bool,
          symbols: Path | None, shard: Shard | None, lib: tuple[str, ...]) -> None:
    """Prove a program's properties (NAME.props.toml) for every input sequence.

    A property says what must never or always hold, what must follow a condition
    (when/then/within) or what must be reachable (docs/prove.md). Needs the 'prove'
    extra (z3-solver).

    FILES are programs (NAME.asi, with NAME.props.toml beside them) or properties files
    (naming their program, or beside NAME.asi); without FILES, every *.props.toml here.
    Each property gets one verdict: proved, refuted (with a counterexample scenario that
    fails under 'asictl sim'), reached (with a witness scenario), unreachable, holds up
    to N cycles (no proof within --depth) or unknown (--timeout).

    Exit status: 0 every property proved or reached, 1 otherwise or the program has
    errors, 2 bad input.

    \b
    Examples:
      asictl prove demos/blink.asi
      asictl prove demos/timer.refuted.props.toml --counterexamples cex   # exit 1: refuted
    """
    try:
        import z3  # noqa: F401
    except ImportError as exc:
        raise missing_extra("asictl prove", "prove", str(exc)) from None
    from asictl.prove.session import Invalid
    from asictl.prove.session import prove as prove_file

    ctx = click.get_current_context()
    reports = []
    pairs = _files(files, properties)
    # split by program where one properties file serves several (--properties)
    keys = [program or props_path for props_path, program in pairs]
    for props_path, program in take_shard(pairs, keys, shard, "files"):
        try:
            report = prove_file(props_path, program=program, lib=lib, depth=depth,
                                timeout_s=timeout / 1000, out_dir=counterexamples, force=force,
                                unroll=unroll, symbols=symbols)
        except Invalid as exc:
            click.echo(exc.text, nl=False, err=True)
            ctx.exit(int(exc.exit_code))
        reports.append(report)
        click.echo(report.warnings, nl=False, err=True)
        if fmt == "text":
            slaves = " ".join(str(a) for a in report.slaves) or "none"
            click.echo(f"{report.properties}: {report.program}, {report.cycle_ms:g} ms "
                       f"cycles, slaves {slaves}")
            for line, bound in report.loops:
                click.echo(f"  backward jump at line {line} followed up to {bound} times "
                           "a cycle")
            for outcome in report.outcomes:
                click.echo("  " + _line(outcome, report.written.get(outcome.prop.name),
                                        report.symbols))
    if fmt == "json":
        click.echo(json.dumps({"files": [_json(r) for r in reports]}, indent=2))
    else:
        outcomes = [o for r in reports for o in r.outcomes]
        counts: dict[str, int] = {}
        for outcome in outcomes:
            counts[outcome.verdict.value] = counts.get(outcome.verdict.value, 0) + 1
        shown = ", ".join(f"{n} {v}" for v, n in counts.items()) or "no properties"
        click.echo(f"{shown} in {format_duration(sum(r.seconds for r in reports) * 1000)}")
    ctx.exit(int(ExitCode.OK if all(r.passed for r in reports) else ExitCode.FAILED))


def _says(outcome: object) -> str:
    """The verdict in words, as the text output says it: ``holds up to 21 cycles``."""
    from asictl.prove.engine import Outcome, Verdict

    assert isinstance(outcome, Outcome)
    if outcome.verdict is not Verdict.BOUNDED:
        return outcome.verdict.value + (f" (trivially: {outcome.trivially})"
                                        if outcome.trivially else "")
    shown = "not reached" if outcome.prop.kind.value == "reachable" else "holds"
    return f"{shown} up to {outcome.depth + 1} cycles"


def _json(report: object) -> dict[str, object]:
    from asictl.prove.session import Report

    assert isinstance(report, Report)
    return {
        "properties": str(report.properties),
        "program": str(report.program),
        "cycle_ms": report.cycle_ms,
        "slaves": list(report.slaves),
        "invariants": report.invariants,
        "loops": [{"line": line, "bound": bound} for line, bound in report.loops],
        "seconds": round(report.seconds, 3),
        "results": [
            {
                "name": o.prop.name,
                "property": o.prop.text(),
                "verdict": o.verdict.value,
                "says": _says(o),
                "cycles": o.depth + 1,
                "seconds": round(o.seconds, 3),
                "scenario": str(report.written[o.prop.name])
                if o.prop.name in report.written else None,
                "note": o.note or None,
                "trivially": o.trivially or None,
                "operands": [{"operand": text, "named": shown, "value": value}
                             for text, shown, value in _operands(o, report.symbols)],
                "first_tick_ms": None if o.phase_us is None else o.phase_us / 1000,
            }
            for o in report.outcomes
        ],
    }
