"""asictl's directives in comments: silencing warnings, declaring host-written flags.

A directive is a comment that starts with ``asictl:``. IL ends a line's code at its
first ``;``, so a directive can never change what the master's own tools read:

- ``; asictl: ignore W711 W714`` silences those warnings on its line, or on the next
  line with code when it stands on a line of its own; without codes, every warning;
- ``; asictl: ignore-file W714`` anywhere in a file silences them in the whole file;
- ``; asictl: host F 10.0, FY 11, FW 12`` says the host writes these flags, so reading
  them without writing them is no mistake (W714).

Text after the codes or operands is a free comment. Errors cannot be silenced.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from asictl.codes import AnalysisCode, all_codes
from asictl.diagnostics import Diagnostic, Severity, Span
from asictl.il.ast import Operand, OperandKind
from asictl.source import SourceText

_DIRECTIVE = re.compile(r";[ \t]*asictl[ \t]*:[ \t]*(?P<word>[^ \t\n,;]*)(?P<rest>.*)", re.I)
_CODE = re.compile(r"[ \t,]*(?P<code>[EW]\d+)(?![0-9A-Za-z_])", re.I)
_HOST_FLAG = re.compile(
    r"[ \t,]*(?:(?P<area>FY|FW)[ \t]*(?P<n>\d+)|F[ \t]*(?P<byte>\d+)[ \t]*\.[ \t]*(?P<bit>\d+))"
    r"(?![0-9A-Za-z_.])",
    re.I,
)
WORDS = ("ignore", "ignore-file", "host")
#: A silence for every warning.
EVERY = frozenset({"*"})


@dataclass
class Directives:
    """What the directives of a program's files say."""

    #: (file, line) -> the codes silenced on that line (EVERY: all warnings)
    lines: dict[tuple[str, int], frozenset[str]] = field(default_factory=dict)
    #: file -> the codes silenced in the whole file
    files: dict[str, frozenset[str]] = field(default_factory=dict)
    #: flag operands the host writes, with the directive that says so
    host_flags: list[tuple[Operand, Span]] = field(default_factory=list)
    #: malformed directives (W721)
    problems: list[Diagnostic] = field(default_factory=list)

    def silences(self, diagnostic: Diagnostic) -> bool:
        span = diagnostic.span
        if diagnostic.severity is not Severity.WARNING or span is None:
            return False
        for codes in (self.files.get(span.file), self.lines.get((span.file, span.line))):
            if codes is not None and ("*" in codes or diagnostic.code in codes):
                return True
        return False

    def apply(self, diagnostics: Iterable[Diagnostic]) -> list[Diagnostic]:
        """The diagnostics left when the silenced ones are taken out."""
        return [d for d in diagnostics if not self.silences(d)]


def read_directives(sources: Mapping[str, SourceText]) -> Directives:
    directives = Directives()
    for name, source in sources.items():
        if "asictl" in source.text.lower():
            _read_file(name, source.text.split("\n"), directives)
    return directives


def _read_file(file: str, lines: list[str], directives: Directives) -> None:
    for index, line in enumerate(lines):
        start = line.find(";")
        match = _DIRECTIVE.match(line, start) if start >= 0 else None
        if match is None:
            continue
        number = index + 1
        word = match["word"].lower()
        at = Span(file, number, start + 1, len(line.rstrip()) - start)
        rest_at = Span(file, number, match.start("rest") + 1, max(1, len(match["rest"])))
        if word == "host":
            flags = _host_flags(match["rest"], rest_at, directives)
            directives.host_flags += [(flag, at) for flag in flags]
            continue
        if word not in ("ignore", "ignore-file"):
            close = difflib.get_close_matches(word, WORDS, n=1)
            hint = f"; did you mean '{close[0]}'?" if close else f" (known: {', '.join(WORDS)})"
            directives.problems.append(_problem(
                f"unknown asictl directive '{match['word']}'{hint}", at))
            continue
        codes = _codes(match["rest"], rest_at, directives)
        if word == "ignore-file":
            directives.files[file] = _union(directives.files.get(file), codes)
        else:
            target = number if line[:start].strip() else _next_code_line(lines, index)
            directives.lines[(file, target)] = _union(directives.lines.get((file, target)), codes)


def _codes(rest: str, at: Span, directives: Directives) -> frozenset[str]:
    codes: set[str] = set()
    known = all_codes()
    pos = 0
    while (match := _CODE.match(rest, pos)) is not None:
        code = match["code"].upper()
        pos = match.end()
        if code not in known:
            directives.problems.append(_problem(f"'{match['code']}' is no asictl code", at))
        elif code.startswith("E"):
            directives.problems.append(_problem(
                f"{code} is an error: errors cannot be ignored", at))
        else:
            codes.add(code)
    return frozenset(codes) if pos else EVERY


def _host_flags(rest: str, at: Span, directives: Directives) -> list[Operand]:
    flags: list[Operand] = []
    pos = 0
    while (match := _HOST_FLAG.match(rest, pos)) is not None:
        pos = match.end()
        if match["area"]:
            kind = OperandKind.FW if match["area"].upper() == "FW" else OperandKind.FY
            number, bit, top = int(match["n"]), -1, 126 if kind is OperandKind.FW else 127
        else:
            kind, number, bit, top = OperandKind.F, int(match["byte"]), int(match["bit"]), 127
        if number > top or bit > 7:
            directives.problems.append(_problem(
                f"'{match.group().strip(' ,')}' is no flag (bytes 0..127, bits 0..7, FW 0..126)",
                at))
            continue
        flags.append(Operand.of(kind, number, bit))
    if not pos:
        directives.problems.append(_problem(
            "'asictl: host' needs the flags the host writes, such as 'F 10.0, FY 11, FW 12'", at))
    return flags


def _next_code_line(lines: list[str], index: int) -> int:
    """The number of the first line after ``index`` with code (not blank, not comment)."""
    for later in range(index + 1, len(lines)):
        if lines[later].partition(";")[0].strip():
            return later + 1
    return index + 1


def _union(old: frozenset[str] | None, new: frozenset[str]) -> frozenset[str]:
    if old is None:
        return new
    if "*" in old or "*" in new:
        return EVERY
    return old | new


def _problem(message: str, span: Span) -> Diagnostic:
    return Diagnostic(Severity.WARNING, AnalysisCode.BAD_DIRECTIVE, message, span)
