"""``asictl xref``: where each operand of a program is read and written."""

from __future__ import annotations

import json

import click

from asictl.build import check as check_program_file
from asictl.cli.discovery import expand
from asictl.cli.options import lib_option
from asictl.cli.terminal import stderr_colour
from asictl.codegen8051.allocate import allocate
from asictl.errors import ExitCode, UserError
from asictl.il.crossref import (
    LEGEND,
    entries,
    modbus_json,
    modbus_table,
    modbus_text,
    xref_json,
    xref_text,
)
from asictl.il.loader import Program
from asictl.source import read_source


@click.command()
@click.argument("files", nargs=-1, metavar="[FILE|DIR]...")
@click.option(
    "--format", "fmt", type=click.Choice(["text", "json"]), default="text", show_default=True,
    help="text: a table per program; json: a list of operands per program.",
)
@click.option(
    "--modbus", is_flag=True,
    help="Show where the Modbus gateway has each operand (coil, discrete input, register).",
)
@lib_option
def xref(files: tuple[str, ...], fmt: str, modbus: bool, lib: tuple[str, ...]) -> None:
    """Cross-reference of each program FILE (- for stdin; a folder means the *.asi files in
    and below it, and no argument the current folder, as 'asictl check' finds them): per
    operand (I, I2, Q, F, T, C,
    bytes, words, variables, labels, blocks), the lines that read it and those that write
    it, as file:line and the instruction. With --modbus: each operand's Modbus address
    on the AS-i/Modbus gateway instead.

    A program with errors gets its diagnostics instead (as 'asictl check' prints them).

    Exit status: 0 done, 1 a program has errors, 2 bad usage or an unreadable file.

    \b
    Examples:
      asictl xref demos/counter.asi
      asictl xref demos/blink.asi --modbus
    """
    ctx = click.get_current_context()
    failed = False
    documents: list[object] = []
    files = tuple(expand(files or (".",)))
    for n, path in enumerate(files):
        built = check_program_file(read_source(path), lib=lib)
        program = built.source_program()
        if built.has_errors or program is None:
            click.echo(built.render(colour=stderr_colour()), nl=False, err=True)
            if not built.has_errors:
                raise UserError(f"{built.name}: the image carries no IL source to cross-reference")
            failed = True
            continue
        if fmt == "json":
            documents.append({"program": built.name, **_document(program, modbus)})
            continue
        if len(files) > 1:
            click.echo(("\n" if n else "") + f"; {built.name}")
        click.echo("\n".join(_table(program, modbus)))
    if fmt == "json":
        click.echo(json.dumps(documents, indent=2))
    ctx.exit(int(ExitCode.FAILED if failed else ExitCode.OK))


def _table(program: Program, modbus: bool) -> list[str]:
    map_counters = program.options.map_counters
    if modbus:
        return modbus_text(modbus_table(entries(program), map_counters=map_counters))
    variables = allocate(program, map_counters=map_counters).variables
    return [f"; {LEGEND}", *xref_text(entries(program, variables=variables))]


def _document(program: Program, modbus: bool) -> dict[str, object]:
    map_counters = program.options.map_counters
    if modbus:
        return {"modbus": modbus_json(modbus_table(entries(program), map_counters=map_counters))}
    variables = allocate(program, map_counters=map_counters).variables
    return {"operands": xref_json(entries(program, variables=variables))}
