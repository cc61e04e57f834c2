"""``asictl fleet backup|verify|status``: every master of a plant at once (docs/fleet.md).

The masters come from the inventory (``plant.toml``, asictl.fleet.inventory); the work on
each is what ``upload``, ``verify`` and ``status`` do on one (asictl.fleet.survey reaches
them a few at a time, each on its own). These commands only choose and show.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any, TypeVar

import click

from asictl.diagnostics import DiagnosticError, printable, render_text
from asictl.errors import ExitCode, UserError
from asictl.fleet.inventory import FleetMaster, read_inventory
from asictl.fleet.survey import DEFAULT_JOBS, Outcome, each_master
from asictl.source import read_source

T = TypeVar("T")
_Command = TypeVar("_Command", bound=Callable[..., object])


def _selection(command: _Command) -> _Command:
    for option in reversed([
        click.argument("inventory", metavar="PLANT.toml", type=click.Path(dir_okay=False)),
        click.option("--line", "lines", multiple=True, metavar="LINE",
                     help="Only the masters on this line (repeatable)."),
        click.option("--group", "groups", multiple=True, metavar="GROUP",
                     help="Only the masters in this group (repeatable)."),
        click.option("--jobs", "-j", type=click.IntRange(1, 64), default=DEFAULT_JOBS,
                     show_default=True, help="Masters reached at once."),
        click.option("--format", "form", type=click.Choice(["text", "json"]), default="text",
                     show_default=True, help="json: one JSON object on stdout."),
    ]):
        command = option(command)
    return command


def _masters(inventory: str, lines: tuple[str, ...], groups: tuple[str, ...]) -> list[
    FleetMaster
]:
    """The inventory's masters the options select; a bad inventory is shown with its
    lines and carets (exit 2)."""
    source = read_source(inventory)
    try:
        plant = read_inventory(source)
    except DiagnosticError as exc:
        click.echo(render_text(exc.diagnostics, {source.name: source.text}), nl=False, err=True)
        click.get_current_context().exit(int(ExitCode.USAGE))
    return plant.select(lines, groups)


def _survey(
    masters: list[FleetMaster], work: Callable[[FleetMaster, Any], T], jobs: int, verb: str
) -> list[Outcome[T]]:
    """``each_master`` with a progress line on a terminal (nothing otherwise)."""
    shown = sys.stderr.isatty()
    width = 0

    def progress(done: int, outcome: Outcome[T]) -> None:
        nonlocal width
        text = (f"{verb} {done}/{len(masters)}: {outcome.master.name} "
                + ("ok" if outcome.ok else "FAILED"))
        click.echo("\r" + printable(text, lines=False).ljust(width), nl=False, err=True)
        width = len(text)

    outcomes = each_master(masters, work, jobs=jobs, progress=progress if shown else None)
    if shown:
        click.echo("\r" + " " * width + "\r", nl=False, err=True)
    return outcomes


def _table(header: tuple[str, ...], rows: list[tuple[str, ...]]) -> str:
    """Columns of text; a master's name or a gateway's answer may hold anything."""
    header, rows = _shown(header), [_shown(row) for row in rows]
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    return "".join(
        "  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip() + "\n"
        for row in [header, *rows]
    )


def _shown(cells: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(printable(cell, lines=False) for cell in cells)


def _short(identity: str | None) -> str:
    return "-" if identity is None else identity[:12]


@click.group("fleet")
def fleet() -> None:
    """Every master of a plant: back up, verify against the archive, show their state.

    The masters are named in an inventory, PLANT.toml (docs/fleet.md):

    \b
      [masters.press-1]
      modbus = "tcp://10.0.0.21:502"
      line = "line-1"
      [masters.pc-1]
      port = "300h"

    \b
    Examples:
      asictl download demos/blink.asi --start
      asictl download demos/counter.asi --port 304h
      asictl fleet status demos/plant.toml
    """


@fleet.command("backup")
@_selection
@click.option("--into", "into", required=True, type=click.Path(file_okay=False),
              metavar="DIR", help="The archive: a git repository (made if it is not there).")
def backup(
    inventory: str, lines: tuple[str, ...], groups: tuple[str, ...], jobs: int, form: str,
    into: str,
) -> None:
    """Upload every master's program into DIR/<master>/ and commit what changed.

    Each master's folder gets the files 'asictl upload' writes (its source, or [RAW]
    records; its symbol table where the master has one), image.hex (the image exactly),
    identity.json and status.json. One commit per run lists the masters that changed; a
    run that changed nothing makes none. A master that does not answer (after its
    time-out, retries and attempts) keeps its last backup, and the others go on.

    Exit status: 0 every master backed up, 1 one or more failed, 2 bad usage or a bad
    inventory.

    \b
    Examples:
      asictl download demos/blink.asi --start
      asictl download demos/counter.asi --port 304h
      asictl fleet backup demos/plant.toml --into archive
    """
    from asictl.fleet.archive import (
        Archive,
        Snapshot,
        program_change,
        snapshot_files,
        snapshot_identity,
        take_snapshot,
    )

    masters = _masters(inventory, lines, groups)
    archive = Archive(Path(into))
    archive.open()
    for lock in archive.recovered:
        click.echo(f"{lock}: removed git's lock left by a git run that was killed (no git "
                   "works in the archive)", err=True)
    outcomes = _survey(masters, take_snapshot, jobs, "backup")
    failed: dict[str, str] = {}
    written: list[str] = []
    paths: list[str] = []
    programs: dict[str, str] = {}
    for outcome in outcomes:
        name = outcome.master.name
        if outcome.value is None:
            failed[name] = outcome.error or "failed"
            continue
        try:
            files = snapshot_files(outcome.master, outcome.value)
            archive.folder(name)  # a link is refused before anything is read through it
            change = program_change(archive.root, name, files)
            paths += archive.write(name, files)
        except UserError as exc:
            failed[name] = str(exc)
            continue
        if change:
            programs[name] = change
        written.append(name)
    commit, changed = archive.commit(paths, failed, programs)
    rows: list[dict[str, Any]] = []
    for outcome in outcomes:
        name = outcome.master.name
        snapshot: Snapshot | None = outcome.value
        program = None if snapshot is None else snapshot_identity(snapshot)
        result = ("changed" if name in changed else "same") if name in written else "FAILED"
        rows.append({
            "master": name, "reached": outcome.master.reached, "result": result,
            "program": program, "attempts": outcome.attempts,
            "seconds": round(outcome.seconds, 3), "error": failed.get(name),
        })
    if form == "json":
        click.echo(json.dumps({"archive": str(archive.root), "commit": commit,
                               "changed": changed, "failed": sorted(failed),
                               "masters": rows}, indent=2))
    else:
        click.echo(_table(
            ("master", "reached", "result", "program", "tries", "time"),
            [(r["master"], r["reached"], r["result"], _short(r["program"]),
              str(r["attempts"]), f"{r['seconds']:.1f} s") for r in rows],
        ), nl=False)
        for name, why in failed.items():
            click.echo(printable(f"{name}: {why}"), err=True)
        done = f"{len(written)} of {len(outcomes)} masters backed up"
        click.echo(
            f"{archive.root}: {done}; "
            + (f"commit {commit[:12]} ({len(changed)} changed)" if commit
               else "nothing changed, no commit")
        )
    if failed:
        click.get_current_context().exit(int(ExitCode.FAILED))


@fleet.command("verify")
@_selection
@click.option("--against", "against", required=True,
              type=click.Path(file_okay=False, exists=True), metavar="DIR",
              help="The archive 'fleet backup' wrote.")
def verify(
    inventory: str, lines: tuple[str, ...], groups: tuple[str, ...], jobs: int, form: str,
    against: str,
) -> None:
    """Which masters run something other than the archive holds, and which do not answer.

    Each master's program is compared with DIR/<master>/image.hex as 'asictl verify'
    compares a file with a master: identical, different (in code, configuration,
    options), no program in the master, or no backup of it in the archive.

    The archive must be as a finished backup leaves it: a lock git left, or a backed-up
    file that differs from the last commit, is named on standard error and fails the run.

    Exit status: 0 every master runs what the archive holds, 1 one or more differ or did
    not answer, or the archive is not in a clean state, 2 bad usage or a bad inventory.

    \b
    Examples:
      asictl download demos/blink.asi --start
      asictl download demos/counter.asi --port 304h
      asictl fleet backup demos/plant.toml --into archive
      asictl fleet verify demos/plant.toml --against archive
    """
    from asictl.fleet.archive import Archive
    from asictl.fleet.compare import Verdict, verify_master

    masters = _masters(inventory, lines, groups)
    unclean = Archive(Path(against)).unclean([master.name for master in masters])
    outcomes = _survey(masters, partial(verify_master, Path(against)), jobs, "verify")
    rows: list[dict[str, Any]] = []
    for outcome in outcomes:
        verdict: Verdict | None = outcome.value
        rows.append({
            "master": outcome.master.name, "reached": outcome.master.reached,
            "result": "unreachable" if verdict is None else verdict.state,
            "archived": None if verdict is None else verdict.archived,
            "running": None if verdict is None else verdict.running,
            "differences": [] if verdict is None else list(verdict.details),
            "networks": [] if verdict is None else list(verdict.networks),
            "error": outcome.error,
            "text": f"unreachable: {outcome.error}" if verdict is None else verdict.describe(),
        })
    drifted = [r["master"] for r in rows if r["result"] != "identical"]
    if form == "json":
        click.echo(json.dumps({"archive": against, "unclean": unclean, "drift": drifted,
                               "masters": rows}, indent=2))
    else:
        for row in rows:
            click.echo(printable(f"{row['master']}: {row['text']}"))
        same = len(rows) - len(drifted)
        click.echo(printable(f"{same} of {len(rows)} masters run what {against} holds"
                             + (f"; not: {', '.join(drifted)}" if drifted else "")))
    for why in unclean:
        click.echo(printable(f"not in a clean state: {why}"), err=True)
    if drifted or unclean:
        click.get_current_context().exit(int(ExitCode.FAILED))


@fleet.command("status")
@_selection
def status(
    inventory: str, lines: tuple[str, ...], groups: tuple[str, ...], jobs: int, form: str,
) -> None:
    """One line per master: what its control program does (or why not) and which program
    its EEPROM holds; the ones that do not answer say why.

    Exit status: 0 every master answered, 1 one or more did not, 2 bad usage or a bad
    inventory.

    \b
    Examples:
      asictl download demos/blink.asi --start
      asictl download demos/counter.asi --port 304h
      asictl fleet status demos/plant.toml
      asictl fleet status demos/plant.toml --line line-1
    """
    from asictl.fleet.compare import Glance, glance

    masters = _masters(inventory, lines, groups)
    outcomes = _survey(masters, glance, jobs, "status")
    rows: list[dict[str, Any]] = []
    for outcome in outcomes:
        seen: Glance | None = outcome.value
        rows.append({
            "master": outcome.master.name, "reached": outcome.master.reached,
            "line": outcome.master.line, "answered": seen is not None,
            "summary": None if seen is None else seen.summary,
            "program": None if seen is None else seen.program, "error": outcome.error,
        })
    if form == "json":
        click.echo(json.dumps({"masters": rows}, indent=2))
    else:
        width = max(len(r["master"]) for r in rows) if rows else 0
        for row in rows:
            text = (f"{row['summary']}; program {_short(row['program'])}" if row["answered"]
                    else f"unreachable: {row['error']}")
            click.echo(printable(f"{row['master'].ljust(width)}  {row['reached']}: {text}"))
    if any(not r["answered"] for r in rows):
        click.get_current_context().exit(int(ExitCode.FAILED))
