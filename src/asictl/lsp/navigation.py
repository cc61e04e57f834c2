"""Go to definition, find references, the outline and folding of a file.

Positions here are the front end's: 1-based lines and columns counted in characters. The
server converts them from and to the editor's units.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import assert_never

from asictl.diagnostics import Span
from asictl.il import ast
from asictl.il.format import operator_length
from asictl.il.references import Role
from asictl.lsp.documents import Analysis


def definition(analysis: Analysis, file: str, line: int, column: int) -> list[Span]:
    """Where the thing at the position is defined: a label, a block's file, a variable's,
    timer's or counter's declaration, a slave's [SETUP] line (also from its operands)."""
    for occurrence in analysis.index.at(file, line, column):
        places = analysis.index.definitions(occurrence.symbol)
        if places:
            return [o.span for o in places]
    return []


def references(
    analysis: Analysis, file: str, line: int, column: int, *, declarations: bool = True
) -> list[Span]:
    """Every place that refers to the thing at the position (its reads and writes, jumps,
    calls), with its definitions and declarations if ``declarations``."""
    found = analysis.index.at(file, line, column)
    if not found:
        return []
    return [
        o.span
        for o in analysis.index.of(found[0].symbol)
        if declarations or o.role not in (Role.DEFINE, Role.DECLARE)
    ]


# ------------------------------------------------------------------ what is where


def covers(span: Span | None, line: int, column: int) -> bool:
    return span is not None and span.line == line and (
        span.column <= column <= span.column + span.length)


def node_at(
    module: ast.Module, line: int, column: int
) -> tuple[ast.Section | None, ast.Section | ast.BodyNode | None]:
    """The section title, or the innermost node of a section's body, at the position."""
    for section in module.sections:
        if covers(section.span, line, column):
            return section, section
        for node in ast.nodes(section):
            if covers(node.span, line, column):
                return section, node
    return None, None


def operator_span(node: ast.Section | ast.BodyNode | None) -> Span | None:
    """The operator of a [PROGRAM] statement: ``JC`` of ``JC = end``."""
    if not isinstance(node, ast.Statement) or isinstance(node, ast.Label) or node.span is None:
        return None
    span = node.span
    return Span(span.file, span.line, span.column, operator_length(node))


# ------------------------------------------------------------- outline and folding


@dataclass
class Outline:
    """A document symbol: a section, a segment of [PROGRAM], a label."""

    name: str
    detail: str
    #: the lines it spans, first and last (1-based)
    lines: tuple[int, int]
    #: what to select: the title, the first statement, the label
    selection: Span
    kind: str
    children: list[Outline] = field(default_factory=list)


def section_lines(module: ast.Module, text: str) -> Iterator[tuple[ast.Section, int, int]]:
    """Each section with its first (the title) and last non-blank line."""
    lines = text.split("\n")
    starts = [s.span.line for s in module.sections if s.span]
    for i, section in enumerate(s for s in module.sections if s.span):
        assert section.span is not None
        stop = starts[i + 1] - 1 if i + 1 < len(starts) else _last_content(module, section)
        while stop > section.span.line and not lines[stop - 1].strip():
            stop -= 1
        yield section, section.span.line, stop


def _last_content(module: ast.Module, section: ast.Section) -> int:
    """The last line of the last section: that of its last node (so [END] stays out)."""
    assert section.span is not None
    last = section.span.line
    for node in ast.nodes(section):
        span = node.span
        if span is not None:
            last = max(last, span.line)
    if isinstance(section, ast.RawSection):
        last += len(section.records)
    return last


def folding_ranges(module: ast.Module, text: str) -> list[tuple[int, int]]:
    """Each section folds from its title to its last line."""
    return [(first, last) for _, first, last in section_lines(module, text) if last > first]


def outline(module: ast.Module, text: str) -> list[Outline]:
    """Sections, the segments of each [PROGRAM] section and its labels."""
    result = []
    lines = text.split("\n")

    def written(span: Span) -> str:
        """A line as written, without its comment (``16: iiio, 1, Eh``)."""
        return lines[span.line - 1].split(";")[0].strip() if span.line <= len(lines) else ""

    for section, first, last in section_lines(module, text):
        assert section.span is not None
        entry = Outline(f"[{section.kind.value}]", "", (first, last), section.span, "section")
        if isinstance(section, ast.ProgramSection):
            entry.children = _segments(section, last)
        elif isinstance(section, ast.SetupSection):
            entry.children = [
                Outline(f"slave {s.address}", written(s.span), (s.span.line, s.span.line),
                        s.span, "slave")
                for s in section.slaves if s.span
            ]
        elif isinstance(section, ast.DeclSection):
            entry.children = [
                Outline(_declared(d), d.to_source(), (d.span.line, d.span.line), d.span,
                        "declaration")
                for d in section.declarations if d.span
            ]
        result.append(entry)
    return result


def _declared(decl: ast.Declaration) -> str:
    match decl:
        case ast.VarDecl(name=name) | ast.FBDecl(name=name):
            return name
        case ast.TimerDecl(number=n):
            return f"T{n}"
        case ast.CounterDecl(number=n):
            return f"C{n}"
        case _:
            assert_never(decl)


def _segments(section: ast.ProgramSection, last_line: int) -> list[Outline]:
    """The segments of a [PROGRAM] section (each ended by ``***``), with their labels."""
    segments: list[Outline] = []
    current: list[ast.Statement] = []

    def close(end: int) -> None:
        spans = [s.span for s in current if s.span]
        if not spans:
            return
        first = next((s for s in current if not isinstance(s, ast.Label)), current[0])
        detail = first.to_source()
        segment = Outline(f"segment {len(segments) + 1}", detail, (spans[0].line, end),
                          spans[0], "segment")
        segment.children = [
            Outline(s.name, "label", (s.span.line, s.span.line), s.span, "label")
            for s in current if isinstance(s, ast.Label) and s.span
        ]
        segments.append(segment)

    for statement in section.statements:
        current.append(statement)
        if isinstance(statement, ast.SegmentEnd) and statement.span:
            close(statement.span.line)
            current = []
    close(last_line)
    return segments
