"""``asictl diff``: what changed between two versions of a program, and whether they
behave the same."""

from __future__ import annotations

import json
from pathlib import Path

import click

from asictl.cli.options import CycleCount, Duration, Number, lib_option
from asictl.errors import ExitCode, UserError, missing_extra
from asictl.observe.symbols import SymbolTable
from asictl.prove import MAX_DEPTH
from asictl.readers.units import Cycles


def _program(path: Path, lib: tuple[str, ...]) -> tuple[object, object]:
    """The build of a program file (.asi, uploaded [RAW] file or .hex) and the IL program
    behind it."""
    from asictl.build import build_file

    built = build_file(path, lib=lib)
    if built.has_errors:
        raise _Bad(built.render())
    program = built.source_program()
    if built.image is None and program is None:
        raise UserError(f"{path}: no program in it")
    return built, program


def _images_only(old: Path, new: Path, first: object, second: object) -> int:
    """Two images one of which carries no IL source: only their code and setup can be
    compared. The exit status: 0 identical, 1 not."""
    from asictl.build import Build

    assert isinstance(first, Build) and isinstance(second, Build)
    a, b = first.image, second.image
    if a is None or b is None:
        raise UserError(f"{old if a is None else new}: no image to compare with an image "
                        "without source")
    same_code = a.code == b.code
    same_setup = (a.flags, a.configuration) == (b.flags, b.configuration)
    if same_code and same_setup:
        click.echo("identical code, options and configuration (no IL source to compare "
                   "network by network): equivalent")
        return int(ExitCode.OK)
    what = [w for w, same in (("code", same_code), ("options or configuration", same_setup))
            if not same]
    click.echo(f"the images differ in {' and '.join(what)} ({len(a.code)} and {len(b.code)} "
               "bytes of code); without IL source neither networks nor behaviour can be "
               "compared")
    return int(ExitCode.FAILED)


class _Bad(Exception):
    def __init__(self, text: str) -> None:
        super().__init__(text)
        self.text = text


@click.command("diff")
@click.argument("old", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("new", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--equivalent", is_flag=True,
              help="Also decide whether both give the same outputs for every input sequence.")
@click.option("--depth", type=CycleCount(MAX_DEPTH), default="20", show_default=True,
              help="Cycles the search for a difference goes to.")
@click.option("--timeout", type=Duration(limit_ms=86_400_000, positive=True), default="30s",
              show_default=True, help="Time for --equivalent (30s, 5min).")
@click.option("--cycle-ms", type=Number(0.1, 10_000),
              help="The program cycle [default: the AS-i cycle of the bus].")
@click.option("--observe", metavar="LIST",
              help='Flags compared besides the outputs, e.g. "FY 10,F 20.0".')
@click.option("--scenario", "scenario_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Where to write the distinguishing scenario [default: "
              "NEW.differs.scenario.toml beside NEW].")
@click.option("--force", is_flag=True,
              help="Replace a file in the way that asictl did not write.")
@click.option("--format", "fmt", type=click.Choice(["text", "json"]), default="text",
              show_default=True)
@click.option("--symbols", type=click.Path(dir_okay=False, path_type=Path),
              help="The symbol table that names operands in the verdict and the scenario "
              "[default: NAME.symbols.toml beside NEW, else beside OLD].")
@lib_option
def diff(old: Path, new: Path, equivalent: bool, depth: Cycles, timeout: float,
         cycle_ms: float | None, observe: str | None, scenario_path: Path | None,
         force: bool, fmt: str, symbols: Path | None, lib: tuple[str, ...]) -> None:
    """Compare two versions of a program network by network (renamed labels and moved
    networks recognised); OLD and NEW are .asi files, uploaded files or .hex images
    that carry their source.

    With --equivalent, also prove that both give the same outputs (and the flags the
    host writes, and --observe) after every cycle for every input sequence, or write a
    scenario that passes on OLD and fails on NEW.

    Exit status: 0 no change (with --equivalent: equivalent), 1 changed (different or
    undecided) or a program has errors, 2 bad input.

    \b
    Examples:
      asictl diff demos/ondelay.asi demos/offdelay.asi   # exit 1: they differ
      asictl diff demos/blink.asi demos/blink.asi --equivalent
    """
    from asictl.il.loader import Program
    from asictl.il.networks import compare

    ctx = click.get_current_context()
    try:
        built_old, first = _program(old, lib)
        built_new, second = _program(new, lib)
    except _Bad as exc:
        click.echo(exc.text, nl=False, err=True)
        ctx.exit(int(ExitCode.FAILED))  # a program with errors, as 'check' exits
    if first is None or second is None:
        ctx.exit(_images_only(old, new, built_old, built_new))
    assert isinstance(first, Program) and isinstance(second, Program)
    changes = compare(first, second)
    differ = [c for c in changes if c.kind != "same"]
    report: dict[str, object] = {
        "old": str(old), "new": str(new),
        "networks": [{"change": c.kind,
                      "old": None if c.old is None else [c.old.first_line, c.old.last_line],
                      "new": None if c.new is None else [c.new.first_line, c.new.last_line]}
                     for c in changes],
    }
    if fmt == "text":
        for change in differ:
            for line in change.lines():
                click.echo(line)
        same = len(changes) - len(differ)
        click.echo(f"{same} network{'s' if same != 1 else ''} the same, {len(differ)} "
                   "changed, moved, added or removed")
    failed = bool(differ)
    if equivalent:
        failed = _equivalence(built_old, built_new, old, new, depth, timeout / 1000, cycle_ms,
                              observe, scenario_path, force, fmt, report, symbols)
    if fmt == "json":
        click.echo(json.dumps(report, indent=2))
    ctx.exit(int(ExitCode.FAILED if failed else ExitCode.OK))


def _equivalence(first: object, second: object, old: Path, new: Path, depth: Cycles,
                 timeout: float, cycle_ms: float | None, observe: str | None,
                 scenario_path: Path | None, force: bool, fmt: str,
                 report: dict[str, object], symbols_path: Path | None) -> bool:
    """Decide and report; True when not proved equivalent."""
    try:
        import z3  # noqa: F401
    except ImportError as exc:
        raise missing_extra("asictl diff --equivalent", "prove", str(exc)) from None
    from asictl.build import Build
    from asictl.files import real_path, write_atomic
    from asictl.observe.names import named_bits
    from asictl.observe.operands import parse_operand
    from asictl.prove.counterexample import difference_text
    from asictl.prove.diff import equivalent as decide
    from asictl.prove.session import check_target

    assert isinstance(first, Build) and isinstance(second, Build)  # with IL source
    extra = []
    for text in (observe or "").split(","):
        if text.strip():
            try:
                extra.append(parse_operand(text.strip()).node)
            except ValueError as exc:
                raise click.BadParameter(str(exc), param_hint="--observe") from None
    result = decide(first, second, timeout_s=timeout, depth=depth, cycle_ms=cycle_ms,
                    observe=extra)
    if result.refused is not None:
        span = result.refused.span
        where = f"{span.file}:{span.line}: " if span else ""
        raise UserError(f"{where}{result.refused}")
    entry: dict[str, object] = {"verdict": result.verdict, "cycles": result.cycles,
                                "seconds": round(result.seconds, 3), "scenario": None}
    lines: list[str] = []
    if result.verdict == "equivalent":
        lines.append(f"equivalent: the same outputs for every input sequence "
                     f"({result.cycle_ms:g} ms cycles, slaves "
                     f"{' '.join(map(str, result.slaves)) or 'none'})")
    elif result.verdict == "different" and result.trace is not None:
        target = scenario_path or new.with_name(new.stem + ".differs.scenario.toml")
        check_target(target, {real_path(old), real_path(new)}, force)
        symbols = _symbols(new, old, explicit=symbols_path)
        write_atomic(target, difference_text(old, new, target, result.trace,
                                             result.host_masks, result.cycle_ms,
                                             result.differences, symbols=symbols,
                                             phase_us=result.phase_us))
        shown = ", ".join(f"{bit} is {a} in {old.name}, {b} in {new.name}"
                          for k, (x, y) in result.differences.items()
                          for bit, a, b in named_bits(k, x, y, symbols))
        lines.append(f"different after cycle {result.cycles}: {shown}")
        lines.append(f"  scenario: {target} (passes on {old.name}, fails on {new.name})")
        entry["scenario"] = str(target)
        entry["differences"] = {k: list(v) for k, v in result.differences.items()}
    else:
        lines.append(f"unknown: {result.note or 'no decision'}")
    report["equivalence"] = entry
    if fmt == "text":
        for line in lines:
            click.echo(line)
    return result.verdict != "equivalent"


def _symbols(*programs: Path, explicit: Path | None = None) -> SymbolTable:
    """The table ``--symbols`` names, else the one beside the first program that has one
    (NAME.symbols.toml)."""
    from asictl.diagnostics import DiagnosticError, render_text
    from asictl.observe.operands import parse_operand
    from asictl.observe.symbols import load_symbols, symbols_for

    def check(text: str) -> str:
        return str(parse_operand(text))

    try:
        if explicit is not None:
            return load_symbols(explicit, check)
        for program in programs:
            table = symbols_for(program, check)
            if table:
                return table
    except DiagnosticError as exc:
        raise UserError(render_text(exc.diagnostics, {}).rstrip()) from None
    return SymbolTable()
