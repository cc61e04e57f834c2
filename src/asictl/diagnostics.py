"""Compiler-style diagnostics shared by every stage that reads source text.

IL checks, the assembler and scenario files all report problems as ``Diagnostic``
values with a source span, so one renderer gives the same ``file:line:col: error:``
format, source line and caret everywhere, and the same JSON and GitHub annotations.
``printable`` is the one way any text from outside (a board, a gateway, a live server, a
file name, a symbol table, a program comment) reaches a terminal.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum


def printable(text: str, *, lines: bool = True) -> str:
    """``text`` as it may reach a terminal, as HTML escapes it for a page: control
    characters (ESC starts a sequence that drives the terminal, rewrites its title or
    clipboard; BEL, backspace and carriage return hide what was written) and every other
    unprintable character are written as Python escapes (``\\x1b``); with ``lines``
    newlines and tabs stay (a message of several lines)."""
    if text.isprintable():
        return text
    return "".join(
        char if char.isprintable() or (lines and char in "\n\t")
        else char.encode("unicode_escape").decode("ascii")
        for char in text
    )


@dataclass(frozen=True, slots=True, order=True)
class Span:
    """A place in a source file: 1-based line and column, and how many columns it covers."""

    file: str
    line: int
    column: int
    length: int = 1

    def __str__(self) -> str:
        return f"{printable(self.file, lines=False)}:{self.line}:{self.column}"


class Severity(StrEnum):
    ERROR = "error"
    WARNING = "warning"
    NOTE = "note"


#: A further place a diagnostic points at, with what it is: "first defined here".
Related = tuple[Span, str]


@dataclass(frozen=True, slots=True)
class Diagnostic:
    """One finding. ``related`` names other places that explain it (the first definition
    of a duplicate, the [SETUP] line of a slave); text output shows each as a ``note:``
    line, editors as related information."""

    severity: Severity
    code: str
    message: str
    span: Span | None = None
    related: tuple[Related, ...] = ()

    @property
    def is_error(self) -> bool:
        return self.severity is Severity.ERROR

    def sort_key(self) -> tuple[str, int, int]:
        s = self.span
        return (s.file, s.line, s.column) if s else ("", 0, 0)


@dataclass
class Reporter:
    """Collects diagnostics so a stage can report all of a file's problems, not only the first."""

    diagnostics: list[Diagnostic] = field(default_factory=list)

    def error(
        self, code: str, message: str, span: Span | None = None, related: Iterable[Related] = ()
    ) -> None:
        self.diagnostics.append(Diagnostic(Severity.ERROR, code, message, span, tuple(related)))

    def warning(
        self, code: str, message: str, span: Span | None = None, related: Iterable[Related] = ()
    ) -> None:
        self.diagnostics.append(
            Diagnostic(Severity.WARNING, code, message, span, tuple(related))
        )

    @property
    def has_errors(self) -> bool:
        return any(d.is_error for d in self.diagnostics)

    def extend(self, diagnostics: Iterable[Diagnostic]) -> None:
        self.diagnostics.extend(diagnostics)


class DiagnosticError(Exception):
    """Raised by a stage that cannot go on; carries everything it found."""

    def __init__(self, diagnostics: Iterable[Diagnostic]) -> None:
        self.diagnostics = sorted(diagnostics, key=Diagnostic.sort_key)
        first = next((d for d in self.diagnostics if d.is_error), None)
        super().__init__(format_line(first) if first else "failed")


def format_line(d: Diagnostic, *, colour: bool = False) -> str:
    return _headline(d.span, d.severity, f"{printable(d.message)} [{d.code}]", colour)


#: ANSI colours of a terminal, as compilers use them: severity coloured, location bold.
_SEVERITY_COLOUR = {Severity.ERROR: "\x1b[1;31m", Severity.WARNING: "\x1b[1;35m",
                    Severity.NOTE: "\x1b[1;36m"}
_BOLD, _CARET, _RESET = "\x1b[1m", "\x1b[1;32m", "\x1b[0m"

#: Diagnostics per file that text output shows by default; the rest are counted, as a
#: compiler does: past the first few hundred, more lines help nobody read a terminal.
TEXT_LIMIT = 200
#: Source lines longer than this are shown as a window around the column.
EXCERPT_WIDTH = 160


def _headline(span: Span | None, severity: Severity, message: str, colour: bool) -> str:
    where = f"{span}: " if span else ""
    if not colour:
        return f"{where}{severity.value}: {message}"
    where = f"{_BOLD}{where}{_RESET}" if where else ""
    return f"{where}{_SEVERITY_COLOUR[severity]}{severity.value}:{_RESET} {message}"


def render_text(
    diagnostics: Iterable[Diagnostic],
    sources: Mapping[str, str],
    *,
    limit: int = TEXT_LIMIT,
    colour: bool = False,
) -> str:
    """Render as a modern compiler does: location line, then source line and caret, then
    each related place as a ``note:`` the same way. ``colour`` adds ANSI colours (for a
    terminal).

    ``sources`` maps file names to their decoded text; a file not in it gets no excerpt.
    At most ``limit`` diagnostics per file are shown (0: all), then one line with the
    number left out. Each file's text is split into lines once, so rendering takes time
    linear in the diagnostics and the text.
    """
    out: list[str] = []
    lines_of: dict[str, list[str]] = {}
    shown: dict[str, int] = {}
    left_out: dict[str, int] = {}
    for d in diagnostics:
        file = d.span.file if d.span else ""
        if limit and shown.get(file, 0) >= limit:
            left_out[file] = left_out.get(file, 0) + 1
            continue
        shown[file] = shown.get(file, 0) + 1
        out.append(format_line(d, colour=colour))
        out += _excerpt(d.span, sources, lines_of, colour)
        for span, note in d.related:
            out.append(_headline(span, Severity.NOTE, printable(note), colour))
            out += _excerpt(span, sources, lines_of, colour)
    for file, count in left_out.items():
        what = f"{count} more diagnostic{'' if count == 1 else 's'}"
        where = printable(file, lines=False) or "asictl"
        out.append(f"{where}: {what} not shown (only the first {limit} are)")
    return "\n".join(out) + ("\n" if out else "")


def _excerpt(
    span: Span | None, sources: Mapping[str, str], lines_of: dict[str, list[str]], colour: bool
) -> list[str]:
    """The source line of ``span`` and a caret under it (nothing if the text is unknown).

    ``lines_of`` keeps each text split into lines, so a file is split once however many
    diagnostics it has. A line of a megabyte (a binary file, generated text) is cut to a
    window around the column, so one diagnostic never prints more than about
    ``EXCERPT_WIDTH`` characters.
    """
    text = sources.get(span.file) if span else None
    if text is None or span is None:
        return []
    if span.file not in lines_of:
        lines_of[span.file] = text.split("\n")
    lines = lines_of[span.file]
    if not 0 < span.line <= len(lines):
        return []
    src = lines[span.line - 1].expandtabs(1).rstrip()
    column = span.column
    if len(src) > EXCERPT_WIDTH:
        start = max(0, min(column - 1 - EXCERPT_WIDTH // 2, len(src) - EXCERPT_WIDTH))
        prefix = "..." if start else ""
        suffix = "..." if start + EXCERPT_WIDTH < len(src) else ""
        src = prefix + src[start : start + EXCERPT_WIDTH] + suffix
        column = column - start + len(prefix)
    # escapes widen what precedes the column; a column past the line's end stays past it
    shown = printable(src, lines=False)
    column = len(printable(src[: column - 1], lines=False)) + 1 + max(0, column - 1 - len(src))
    src = shown
    length = min(span.length, max(1, len(src) - column + 1))
    caret = "^" + "~" * max(0, length - 1)
    if colour:
        caret = f"{_CARET}{caret}{_RESET}"
    return [f"  {src}", "  " + " " * (column - 1) + caret]


def render_json(diagnostics: Iterable[Diagnostic]) -> str:
    """A list of objects; ``related`` (file, line, column, message) only where there is one."""
    items = []
    for d in diagnostics:
        item: dict[str, object] = {
            "file": d.span.file if d.span else None,
            "line": d.span.line if d.span else None,
            "column": d.span.column if d.span else None,
            "severity": d.severity.value,
            "code": d.code,
            "message": d.message,
        }
        if d.related:
            item["related"] = [
                {"file": span.file, "line": span.line, "column": span.column, "message": note}
                for span, note in d.related
            ]
        items.append(item)
    return json.dumps(items, indent=2) + "\n"


def _escape_github(value: str, *, property_value: bool = False) -> str:
    value = value.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")
    if property_value:
        value = value.replace(":", "%3A").replace(",", "%2C")
    return value


def github_command(
    kind: str, message: str, *, file: str | None = None, line: int | None = None,
    column: int | None = None, title: str | None = None,
) -> str:
    """One GitHub Actions workflow command (``::error file=...,line=...::message``)."""
    props = [f"file={_escape_github(file, property_value=True)}"] if file else []
    props += [f"line={line}"] if line is not None else []
    props += [f"col={column}"] if column is not None else []
    props += [f"title={_escape_github(title, property_value=True)}"] if title else []
    return f"::{kind} {','.join(props)}::{_escape_github(message)}"


def render_github(diagnostics: Iterable[Diagnostic]) -> str:
    """GitHub Actions workflow commands, so problems show up as annotations on the diff."""
    out = []
    for d in diagnostics:
        kind = "error" if d.is_error else "warning" if d.severity is Severity.WARNING else "notice"
        span = d.span
        message = d.message + "".join(f"\nnote: {where}: {note}" for where, note in d.related)
        out.append(github_command(
            kind, message, file=span.file if span else None, line=span.line if span else None,
            column=span.column if span else None, title=d.code,
        ))
    return "\n".join(out) + ("\n" if out else "")
