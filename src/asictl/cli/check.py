"""``asictl check``: read files exactly as the compiler would and report every problem."""

from __future__ import annotations

import os
from pathlib import Path

import click

from asictl.build import Build
from asictl.build import check as check_program_file
from asictl.cli.discovery import BLOCK_SUFFIX, PROGRAM_SUFFIX, expand
from asictl.cli.options import lib_option
from asictl.cli.terminal import stderr_colour
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


class _Checker:
    """Checks each file once: a function-block file's callers are found by checking the
    programs beside it, which may be named on the command line as well."""

    def __init__(self, dialect: Dialect, lib: tuple[str, ...]) -> None:
        self.dialect = dialect
        self.lib = lib
        #: path -> its check, or why it could not be checked
        self.results: dict[str, Build | str] = {}

    def result(self, path: str) -> Build | str:
        if path not in self.results:
            self.results[path] = self._check(path)
        return self.results[path]

    def _check(self, path: str) -> Build | str:
        try:
            source = read_source(path)
        except UserError as exc:
            return str(exc)
        try:
            return check_program_file(source, dialect=self.dialect, lib=self.lib)
        except UserError as exc:  # an Intel HEX file that holds no valid image
            return f"{source.name}: {exc}"

    def callers(self, block: Path) -> list[str]:
        """The programs beside a function-block file that call it (and so read it)."""
        programs = sorted(
            p for p in block.parent.iterdir()
            if p.is_file() and p.name.lower().endswith(PROGRAM_SUFFIX)
        )
        return [
            str(p) for p in programs
            if isinstance(built := self.result(str(p)), Build) and _reads(built, block)
        ]


def _reads(built: Build, block: Path) -> bool:
    for name in built.texts:
        try:
            if os.path.samefile(name, block):
                return True
        except OSError:
            continue
    return False


def _targets(paths: list[str], checker: _Checker, *, quiet: bool) -> list[str]:
    """The files to check: a function-block file stands for the programs beside it that
    call it (its errors are what they see of it), else for itself."""
    targets: list[str] = []
    for path in paths:
        if path.lower().endswith(BLOCK_SUFFIX) and Path(path).is_file():
            callers = checker.callers(Path(path))
            if callers:
                if not quiet:
                    click.echo(
                        f"asictl: note: {path}: checked through the programs that call it: "
                        + ", ".join(callers),
                        err=True,
                    )
                targets.extend(callers)
                continue
        targets.append(path)
    return list(dict.fromkeys(targets))


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
@click.argument("files", nargs=-1, metavar="[FILE|DIR]...")
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
@lib_option
@click.option(
    "--exclude", multiple=True, metavar="GLOB",
    help="Leave out files and folders matching GLOB (by path or name; repeatable), e.g. "
    "--exclude 'old' --exclude '*_draft.asi'.",
)
@click.option(
    "--max-diagnostics", type=click.IntRange(min=0), default=TEXT_LIMIT, show_default=True,
    metavar="N", help="Text output shows the first N diagnostics of each file and counts the "
    "rest (0: all). json and github always list all.",
)
@click.option("-q", "--quiet", is_flag=True, help="No summary line.")
def check(
    files: tuple[str, ...], fmt: str, werror: bool, dialect: str, lib: tuple[str, ...],
    exclude: tuple[str, ...], max_diagnostics: int, quiet: bool,
) -> None:
    """Check IL source files: FILE... (- for stdin), a folder (its *.asi files), or without
    arguments the *.asi files in and below the current folder.

    Folders whose name starts with a dot (.git, .venv...), build, dist, __pycache__ and
    node_modules are not searched. A function-block file (.fb) is checked through the
    programs beside it that call it, or on its own when none does.

    Reads each main program and the function-block files it calls, and reports every
    syntax and semantic problem as file:line:col: error|warning: message [code].
    Text output shows the first 200 of each file (--max-diagnostics) and then how many
    more there are; the summary line counts them all. A folder that cannot be read is
    reported as unreadable.

    Exit status: 0 no errors, 1 errors found (or warnings, with --werror), 2 bad usage or
    an unreadable file.

    \b
    Examples:
      asictl check demos
      asictl check demos/blink.asi --format json --werror
    """
    ctx = click.get_current_context()
    diagnostics: list[Diagnostic] = []
    sources: dict[str, str] = {}
    checker = _Checker(Dialect(dialect), lib)
    folders: list[str] = []
    paths = _targets(expand(files or (".",), exclude, unreadable=folders), checker, quiet=quiet)
    for problem in folders:
        click.echo(f"asictl: error: {problem}", err=True)
    unreadable = len(folders)
    for path in paths:
        result = checker.result(path)
        if isinstance(result, str):
            click.echo(f"asictl: error: {result}", err=True)
            unreadable += 1
            continue
        diagnostics.extend(result.diagnostics)
        sources.update(result.texts)

    if fmt == "json":
        click.echo(render_json(diagnostics), nl=False)
    elif fmt == "github":
        click.echo(render_github(diagnostics), nl=False)
    else:
        text = render_text(diagnostics, sources, limit=max_diagnostics, colour=stderr_colour())
        click.echo(text, nl=False, err=True)
    if not quiet:
        click.echo(_summary(len(paths), diagnostics, unreadable), err=True)

    failed = any(d.is_error or (werror and d.severity is Severity.WARNING) for d in diagnostics)
    if unreadable:
        ctx.exit(int(ExitCode.USAGE))
    ctx.exit(int(ExitCode.FAILED if failed else ExitCode.OK))
