"""``asictl force``, ``unforce``, ``watch``: the online commands a PLC runtime offers
beyond reading and writing (docs/commissioning.md, "Forcing", "Watch tables").

Operands are named as ``asictl write`` names them, and by the names of the symbol
table the program on the master carries (host/symbols.py).
"""

from __future__ import annotations

import itertools
import json
import time
from dataclasses import asdict
from typing import TYPE_CHECKING, Unpack

import click

from asictl.cli.board_options import BoardOptions, board_options, open_master
from asictl.cli.options import Duration
from asictl.diagnostics import printable
from asictl.errors import ExitCode, UserError
from asictl.host.force_list import Entry, ForcedValue, forced_values
from asictl.host.forcing import forced
from asictl.host.master import Master
from asictl.host.status import StoredProgram
from asictl.host.symbols import Names

if TYPE_CHECKING:
    # watch's conditions bring their grammar (lark): only 'asictl watch' loads them
    from asictl.host.watch import Watched


def _forced_text(values: list[ForcedValue]) -> str:
    """``FORCE 2: F 10.0 = 1, FY 12 = 85`` (the count as a PLC's FORCE lamp shows it)."""
    if not values:
        return "nothing forced"
    return f"FORCE {len(values)}: " + ", ".join(map(str, values))


def _show(master: Master, entries: list[Entry], names: Names, as_json: bool) -> None:
    values = forced_values(entries, names.table if entries else None)
    if as_json:
        click.echo(json.dumps({"forced": [asdict(v) for v in values]}, indent=2))
    else:
        for value in values:
            click.echo(str(value))
    click.echo(f"{master.name}: {_forced_text(values)}", err=True)


@click.command("force")
@click.argument("assignments", nargs=-1)
@click.option("--list", "list_", is_flag=True, help="Show the force list (the default "
              "without OPERAND=VALUE).")
@click.option("--json", "as_json", is_flag=True, help="The force list as JSON on stdout.")
@board_options
def force(
    assignments: tuple[str, ...], list_: bool, as_json: bool, **board: Unpack[BoardOptions]
) -> None:
    """Force inputs, outputs and flags: 'I 1.0=1' (what the program reads), 'Q 2.0=1'
    (what the slave receives, whatever the program writes), 'F 10.0=1', 'FY 12=0x55'
    (written again after every program cycle), 'Q 2=0b1010' (a slave's four bits),
    'QB 2=0x5A', or a name of the program's symbol table ('Motor=1'). Forces hold until
    'asictl unforce' releases them, across commands and restarts; they are listed on
    stdout, and 'status' marks them. Emulated boards only: the PC2 firmware has no force
    list.

    Exit status: 0 forced (or listed), 1 refused (a real board, a gateway), 2 bad usage
    (nothing is forced then).

    \b
    Examples:
      asictl force "F 10.0=1" "FY 12=0x55"
      asictl force --list
    """
    from asictl.host.forcing import force as force_all

    with open_master(**board) as master:
        names = Names(master)
        parsed = [names.assignment(text, example="F 10.0=1") for text in assignments]
        entries = force_all(master, parsed) if parsed else forced(master)
        _show(master, entries, names, as_json)


@click.command("unforce")
@click.argument("operands", nargs=-1)
@click.option("--all", "all_", is_flag=True, help="Release every force.")
@board_options
def unforce(operands: tuple[str, ...], all_: bool, **board: Unpack[BoardOptions]) -> None:
    """Release forced operands ('F 10.0', 'FY 12', 'Q 2', a symbol's name), or all of
    them with --all; the program's own values take over in its next cycle. What is still
    forced is listed on stdout.

    Exit status: 0 released, 1 refused (a real board, a gateway) or an operand named was
    not forced (the others are released), 2 bad usage.

    \b
    Examples:
      asictl force "F 10.0=1" "Q 2.0=1"
      asictl unforce "F 10.0"
      asictl unforce --all
    """
    from asictl.host.forcing import not_forced
    from asictl.host.forcing import unforce as release

    if bool(operands) == all_:
        raise UserError("name the operands to release, or --all (not both)", ExitCode.USAGE)
    with open_master(**board) as master:
        names = Names(master)
        parsed = None if all_ else [(names.operand(text), text) for text in operands]
        missing = not_forced(forced(master), parsed) if parsed is not None else []
        released, entries = release(master, parsed)
        _show(master, entries, names, False)
    if missing:
        others = " (the others are released)" if released else ""
        raise UserError(f"{', '.join(missing)}: not forced{others}", ExitCode.FAILED)


# --------------------------------------------------------------------------- watch


@click.command("watch")
@click.argument("operands", nargs=-1)
@click.option("--table", "table", type=click.Path(dir_okay=False), metavar="FILE.watch.toml",
              help='A watch table: watch = ["F 10.0", "Motor", ...] (added to OPERANDS).')
@click.option("--interval", type=Duration(positive=True), default="0.2s", show_default=True,
              help="How often the values are read (250ms, 1s, ...).")
@click.option("--duration", type=Duration(positive=True), default=None,
              help="Stop after this long (10s, 2m); default: until Ctrl-C.")
@click.option("--format", "format_", type=click.Choice(["text", "json"]), default="text",
              show_default=True, help="json: one JSON object a line.")
@board_options
def watch(
    operands: tuple[str, ...], table: str | None, interval: float, duration: float | None,
    format_: str, **board: Unpack[BoardOptions],
) -> None:
    """Watch operands on the master: a line for each value at the start, then one for
    each change, until --duration or Ctrl-C. OPERANDS are inputs, outputs and flags as
    'write' names them ('F 10.0', 'FY 11', 'Q 2', 'IB 4'), timers and counters ('T 1',
    'TV 1' its remaining milliseconds, 'CV 0' a count; emulated boards only), names of
    the symbol table the program on the master carries, or conditions over them
    ('Forward and not Stop': 1 while it holds; docs/conditions.md). Text lines are 'TIME OPERAND
    (NAME) VALUE' with the value in decimal, hex and binary; JSON lines are {"operand",
    "symbol", "value", "time"} with time in seconds since the watch began.

    A board that runs only during a command (not under 'asictl serve') runs its own
    time as fast as it can: --duration is then master time.

    Exit status: 0 watched, 1 the master did not answer or the live board's server
    ended, 2 bad usage.

    \b
    Examples:
      asictl download demos/blink.asi --start
      asictl watch "Q 31.0" --duration 2s
      asictl watch "Q 31.0" "T 0" --format json --duration 1s
      asictl watch "Q 31.0 and not T 0" --duration 1s
    """
    from asictl.cli.board_options import master_address, master_wait
    from asictl.diagnostics import DiagnosticError, render_text
    from asictl.host.connection import open_board
    from asictl.host.status import read_program
    from asictl.host.watch import read_table, watch_list
    from asictl.source import read_source

    period = interval / 1000
    limit = duration / 1000 if duration is not None else None
    def refused(exc: DiagnosticError) -> click.exceptions.Exit:
        texts = {table: read_source(table).text} if table else {}
        click.echo(render_text(exc.diagnostics, texts), nl=False, err=True)
        return click.exceptions.Exit(int(ExitCode.USAGE))

    try:
        listed = read_table(read_source(table)) if table else None
    except DiagnosticError as exc:
        raise refused(exc) from None
    items = [*(listed.items if listed else ()), *operands]
    if not items:
        raise UserError("nothing to watch: name operands or give --table FILE.watch.toml",
                        ExitCode.USAGE)
    with open_master(**board) as master:
        loaded = master.action is not None and master.action.live is None
        if loaded and limit is None:
            raise UserError(
                f"{master.name} runs only during a command: give --duration, or keep it "
                "running with 'asictl serve'", ExitCode.USAGE)
        program = read_program(master.transport)
        try:
            watched = watch_list(Names(master, program.symbols), items, listed)
        except DiagnosticError as exc:
            raise refused(exc) from None
        lines = _WatchLines(watched, format_)
        if loaded:  # the board runs only in this command: master time passes as it waits
            wait = master_wait(master)
            for reads in itertools.count():
                lines.show(_read(master, program, watched), reads * period)
                if limit is not None and (reads + 1) * period > limit + 1e-9:
                    return
                wait(period * 1000)
    # a live board, a real one, a gateway: one session a read, as the monitor's refresh,
    # so that other commands reach the board between reads
    address = master_address(**board)
    served = master.action is not None
    begun = time.monotonic()
    try:
        for reads in itertools.count():
            with open_board(address) as master:
                if served and (master.action is None or master.action.live is None):
                    # the server ended: what the state file holds would be no live value
                    raise UserError(f"{master.name}: the live board is no longer served "
                                    "('asictl serve' ended); the watch stops",
                                    ExitCode.FAILED)
                now = _read(master, program, watched)
            lines.show(now, time.monotonic() - begun if reads else 0.0)
            due = (reads + 1) * period
            if limit is not None and due > limit + 1e-9:
                return
            time.sleep(max(0.0, due - (time.monotonic() - begun)))
    except KeyboardInterrupt:
        pass


def _read(master: Master, program: StoredProgram, watched: list[Watched]) -> list[int]:
    from asictl.host.watch import values

    quick = master.quick_status
    return values(quick(program) if quick is not None else master.status(), watched)


class _WatchLines:
    """Prints a line for each watched value that differs from the one shown last."""

    def __init__(self, watched: list[Watched], format_: str) -> None:
        self.watched = watched
        self.format = format_
        self.shown: list[int | None] = [None] * len(watched)

    def show(self, now: list[int], elapsed: float) -> None:
        for k, (entry, value) in enumerate(zip(self.watched, now, strict=True)):
            if value != self.shown[k]:
                self.shown[k] = value
                click.echo(_watch_line(entry, value, elapsed, self.format))


def _watch_line(entry: Watched, value: int, elapsed: float, format_: str) -> str:
    if format_ == "json":
        return json.dumps({"operand": entry.text, "symbol": entry.symbol, "value": value,
                           "time": round(elapsed, 3)})
    bits = entry.width
    digits = max(1, (bits + 3) // 4)
    label = printable(entry.label, lines=False)  # a symbol table's name may hold anything
    return (f"{elapsed:8.3f}s  {label:<24} {value:>5}  {value:0{digits}X}h  "
            f"{value:0{bits}b}b")
