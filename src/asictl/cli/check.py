"""``asictl check``: read files exactly as the compiler would and report every problem."""

from __future__ import annotations

import os
from pathlib import Path

import click

from asictl.build import check as check_program_file
from asictl.diagnostics import (
    TEXT_LIMIT,
    Diagnostic,
    Severity,
    render_github,
    render_json,
    render_text,
)
from asictl.errors import ExitCode, UserError
from asictl.il.checks import Dialect
from asictl.source import read_source


def _expand(paths: tuple[str, ...]) -> tuple[list[str], list[str]]:
    """Files as given, a directory standing for every ``*.asi`` below it; and the folders
    below that could not be read (each a message), which a plain rglob would skip silently.
    """
    files: list[str] = []
    unreadable: list[str] = []
    for path in paths:
        if path != "-" and Path(path).is_dir():
            found, problems = _asi_files(path)
            unreadable += problems
            if not found and not problems:
                raise UserError(f"{path}: no .asi files in this directory")
            files.extend(found)
        else:
            files.append(path)
    return files, unreadable


def _asi_files(directory: str) -> tuple[list[str], list[str]]:
    problems: list[str] = []

    def failed(error: OSError) -> None:
        problems.append(f"{error.filename}: cannot read: {error.strerror or error}")

    found = [
        str(Path(folder) / name)
        for folder, _, names in os.walk(directory, onerror=failed)
        for name in names
        if Path(name).suffix.lower() == ".asi"
    ]
    return sorted(found), problems


def _summary(files: int, diagnostics: list[Diagnostic], unreadable: int) -> str:
    errors = sum(d.severity is Severity.ERROR for d in diagnostics)
    warnings = sum(d.severity is Severity.WARNING for d in diagnostics)

    def n(count: int, word: str) -> str:
        return f"{count} {word}{'' if count == 1 else 's'}"

    parts = [n(errors, "error"), n(warnings, "warning")]
    if unreadable:
        parts.append(f"{unreadable} unreadable")
    return f"checked {n(files, 'file')}: {', '.join(parts)}"


@click.command()
@click.argument("files", nargs=-1, required=True, metavar="FILE...")
@click.option(
    "--format", "fmt", type=click.Choice(["text", "json", "github"]), default="text",
    show_default=True,
    help="text: compiler-style messages on stderr; json: a list of diagnostics on stdout; "
    "github: GitHub Actions annotations on stdout.",
)
@click.option("--werror", is_flag=True, help="Treat warnings as errors (exit 1).")
@click.option(
    "--dialect", type=click.Choice([d.value for d in Dialect]), default=Dialect.CONTROL2.value,
    show_default=True, help="control1 reports every AS-i Control II-only feature as an error.",
)
@click.option(
    "--lib", "lib", multiple=True, type=click.Path(file_okay=False),
    help="Also look for function-block files here (repeatable; also $ASICTL_LIB).",
)
@click.option(
    "--max-diagnostics", type=click.IntRange(min=0), default=TEXT_LIMIT, show_default=True,
    metavar="N", help="Text output shows the first N diagnostics of each file and counts the "
    "rest (0: all). json and github always list all.",
)
@click.option("-q", "--quiet", is_flag=True, help="No summary line.")
def check(
    files: tuple[str, ...], fmt: str, werror: bool, dialect: str, lib: tuple[str, ...],
    max_diagnostics: int, quiet: bool,
) -> None:
    """Check IL source files (FILE... or - for stdin; a directory means its *.asi files).

    Reads each main program and the function-block files it calls, and reports every
    syntax and semantic problem as file:line:col: error|warning: message [code].
    Text output shows the first 200 of each file (--max-diagnostics) and then how many
    more there are; the summary line counts them all.

    Exit status: 0 no errors, 1 errors found (or warnings, with --werror), 2 bad usage or
    an unreadable file.
    """
    ctx = click.get_current_context()
    diagnostics: list[Diagnostic] = []
    sources: dict[str, str] = {}
    paths, folders = _expand(files)
    for problem in folders:
        click.echo(f"asictl: error: {problem}", err=True)
    unreadable = len(folders)
    for path in paths:
        try:
            source = read_source(path)
        except UserError as exc:
            click.echo(f"asictl: error: {exc}", err=True)
            unreadable += 1
            continue
        try:
            result = check_program_file(source, dialect=Dialect(dialect), lib=lib)
        except UserError as exc:  # an Intel HEX file that holds no valid image
            click.echo(f"asictl: error: {source.name}: {exc}", err=True)
            unreadable += 1
            continue
        diagnostics.extend(result.diagnostics)
        sources.update(result.texts)

    if fmt == "json":
        click.echo(render_json(diagnostics), nl=False)
    elif fmt == "github":
        click.echo(render_github(diagnostics), nl=False)
    else:
        click.echo(render_text(diagnostics, sources, limit=max_diagnostics), nl=False, err=True)
    if not quiet:
        click.echo(_summary(len(paths), diagnostics, unreadable), err=True)

    failed = any(d.is_error or (werror and d.severity is Severity.WARNING) for d in diagnostics)
    if unreadable:
        ctx.exit(int(ExitCode.USAGE))
    ctx.exit(int(ExitCode.FAILED if failed else ExitCode.OK))
