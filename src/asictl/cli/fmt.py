"""``asictl fmt``: lay IL files out canonically, in place, or check that they are."""

from __future__ import annotations

import difflib
import sys
from pathlib import Path

import click

from asictl.cli.discovery import programs_in
from asictl.diagnostics import DiagnosticError, render_text
from asictl.errors import ExitCode, UserError
from asictl.files import write_atomic
from asictl.il.format import format_source
from asictl.source import SourceText, decode, read_source

#: The files a directory stands for: main programs and function blocks.
SUFFIXES = (".asi", ".fb")


def _expand(paths: tuple[str, ...]) -> list[str]:
    files: list[str] = []
    for path in paths:
        if path != "-" and Path(path).is_dir():  # without hidden folders and build outputs
            found = [str(p) for p in programs_in(Path(path), suffixes=SUFFIXES)]
            if not found:
                raise UserError(f"{path}: no .asi or .fb files in this directory")
            files.extend(found)
        else:
            files.append(path)
    return files


def _diff(source: SourceText, formatted: bytes) -> str:
    return "".join(
        difflib.unified_diff(
            source.text.splitlines(keepends=True), decode(formatted).splitlines(keepends=True),
            source.name, f"{source.name} (formatted)",
        )
    )


def _summary(files: int, changed: int, failed: int, dry: bool) -> str:
    def n(count: int) -> str:
        return f"{count} file{'' if count == 1 else 's'}"

    parts = [f"{n(changed)} {'would be reformatted' if dry else 'reformatted'}",
             f"{files - changed - failed} unchanged"]
    if failed:
        parts.append(f"{failed} with syntax errors")
    return "fmt: " + ", ".join(parts)


@click.command()
@click.argument("files", nargs=-1, metavar="[FILE|DIR]...")
@click.option("--check", is_flag=True,
              help="Change nothing; list the files that would change and exit 1 if any.")
@click.option("--diff", "show_diff", is_flag=True,
              help="Change nothing; print what would change as a unified diff.")
def fmt(files: tuple[str, ...], check: bool, show_diff: bool) -> None:
    """Lay out IL files canonically (FILE... or - for stdin to stdout; a directory means
    its *.asi and *.fb files; without arguments, those in and below the current folder, as
    'asictl check' finds them).

    Labels, operators, operands and comments go into columns; words, comments, blank
    lines, the encoding and the line ends stay as they are. A file with syntax errors is
    not touched: its errors are reported instead.

    Exit status: 0 done (or, with --check, nothing would change), 1 a file would change
    (--check) or has syntax errors, 2 bad usage or an unreadable file.

    \b
    Examples:
      asictl fmt --check demos
      asictl fmt --diff demos/blink.asi
    """
    ctx = click.get_current_context()
    changed: list[str] = []
    failed = unreadable = 0
    paths = _expand(files or (".",))
    for path in paths:
        try:
            source = read_source(path)
        except UserError as exc:
            click.echo(f"asictl: error: {exc}", err=True)
            unreadable += 1
            continue
        try:
            formatted = format_source(source)
        except DiagnosticError as exc:
            click.echo(render_text(exc.diagnostics, {source.name: source.text}), nl=False,
                       err=True)
            click.echo(f"{source.name}: not formatted: it has syntax errors", err=True)
            failed += 1
            continue
        if path == "-" and not (check or show_diff):
            sys.stdout.buffer.write(formatted)
            continue
        if formatted == source.raw:
            continue
        changed.append(source.name)
        if show_diff:
            click.echo(_diff(source, formatted), nl=False)
        elif check:
            click.echo(f"would reformat {source.name}", err=True)
        else:
            write_atomic(path, formatted)
            click.echo(f"reformatted {source.name}", err=True)

    if paths != ["-"]:
        dry = check or show_diff
        click.echo(_summary(len(paths) - unreadable, len(changed), failed, dry), err=True)
    if unreadable:
        ctx.exit(int(ExitCode.USAGE))
    if failed or (check and changed):
        ctx.exit(int(ExitCode.FAILED))
