"""Reading IL source text into an ``ast.Module``, with every syntax error of the file.

The grammar is ``grammar/il.lark``, read by lark's LALR parser with the contextual lexer.
A file is parsed in one go; on a syntax error the parser resumes on the next line (the
language is line-based), in the section it was reading, so one run reports every error:

1. parse from the current position to the end with the start rule of the section in
   effect (``start`` before any section, ``program_rest`` inside a [PROGRAM], ...);
2. on an error in line L, parse again only up to the start of L (that part was read
   without error, so it parses clean) and keep its nodes; report the error; go on at
   line L+1. After an unknown title, or text before the first title, go on at the next
   title instead: the lines in between belong to no known section.

Each failed attempt stops at its error, so an erroneous file costs about two parses, a
clean one exactly one. Each attempt starts with the line count where the last one left
off (lark would count the lines before the slice again every time: quadratic in the
number of errors). Only syntax is checked here; ranges, names and labels are the
semantic checks' job.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Callable
from copy import copy
from importlib.resources import files
from typing import TypedDict

from lark import Lark, Token
from lark.exceptions import UnexpectedInput
from lark.lexer import LexerState, LineCounter
from lark.utils import TextSlice

from asictl.diagnostics import Diagnostic, Span
from asictl.files import grammar_cache
from asictl.il import ast
from asictl.il.lean_parser import LeanParser
from asictl.il.syntax_errors import diagnose
from asictl.il.transformer import AstBuilder, Piece, SectionItem
from asictl.source import SourceText, from_string

#: Keywords and operand marks: never names, so that "A FY 1" and "JU = A" fail plainly.
RESERVED = frozenset(
    [
        "A", "AN", "O", "ON", "N", "S", "R", "L", "T", "F", "CU", "CD", "STP", "BE", "BEC",
        "BEU", "JU", "JC", "FB", "PARAM", "ASM", "BYTE", "TIMER", "COUNTER", "AND", "OR",
        "NOT", "I", "I2", "Q", "C", "IB", "I2B", "QB", "FY", "FW", "PSEG", "KT", "KC", "KP",
        "KB", "KW",
    ]
)

_TITLES = {
    "OPTIONS_TITLE": (ast.SectionKind.OPTIONS, ast.OptionsSection),
    "SETUP_TITLE": (ast.SectionKind.SETUP, ast.SetupSection),
    "DECL_TITLE": (ast.SectionKind.DECL, ast.DeclSection),
    "PROGRAM_TITLE": (ast.SectionKind.PROGRAM, ast.ProgramSection),
    "GATING_TITLE": (ast.SectionKind.GATING, ast.GatingSection),
    "ASSEMBLY_TITLE": (ast.SectionKind.ASSEMBLY, ast.AssemblySection),
    "RAW_TITLE": (ast.SectionKind.RAW, ast.RawSection),
}
_START_RULES = {None: "start"} | {kind: f"{kind.value.lower()}_rest" for kind, _ in
                                  _TITLES.values()}
_READERS = threading.local()


def _reserve(token: Token) -> Token:
    if token.value.upper() in RESERVED:
        token.type = "RESERVED"
    return token


def grammar_text() -> str:
    return files("asictl").joinpath("grammar/il.lark").read_text(encoding="utf-8")


class LarkOptions(TypedDict):
    parser: str
    lexer: str
    start: list[str]
    lexer_callbacks: dict[str, Callable[[Token], Token]]


def lark_options() -> LarkOptions:
    """The options the grammar is built with (tests add ``strict=True``)."""
    return {
        "parser": "lalr",
        "lexer": "contextual",
        "start": list(_START_RULES.values()),
        "lexer_callbacks": {"NAME": _reserve},
    }


class _Reader:
    """The built parser and what error reporting needs from it; built once per process."""

    def __init__(self) -> None:
        self.builder = AstBuilder()
        self.lark = Lark(
            grammar_text(), transformer=self.builder, cache=grammar_cache("il"), **lark_options()
        )
        self.keywords = {
            t.name: t.pattern.value for t in self.lark.terminals if t.pattern.type == "str"
        }
        titles = [*_TITLES, "END_REST"]
        self.title_line = re.compile(
            "[ \t\f\v]*(?:"
            + "|".join(f"(?P<{n}>{self.lark.get_terminal(n).pattern.to_regexp()})" for n in titles)
            + ")"
        )
        self._accepts: dict[tuple[int, ...], frozenset[str]] = {}
        # lark's lexer and parser loop, with less work per token (same tokens and errors)
        self.parser = LeanParser(self.lark.parser.parser.parser, self.lark.parser.lexer)

    def parse(
        self, text: str, start: int, end: int, rule: str, lines: LineCounter
    ) -> list[Piece]:
        """The flat list (see ``AstBuilder.start``) of ``text[start:end]`` read with
        ``rule``; ``lines`` is the line count at ``start``.

        (What ``Lark.parse`` does with a ``TextSlice``, except that it counts the lines
        from the beginning of ``text`` again, and that it reads with ``LeanParser``. With
        transformer= the parser returns what the builder's method for the start rule
        returns, the flat list.)
        """
        state = LexerState(TextSlice(text, start, end), copy(lines))
        pieces: list[Piece] = self.parser.parse(state, rule)
        return pieces

    def expected(self, error: UnexpectedInput) -> frozenset[str]:
        """The terminals the parser could take where it failed.

        lark's ``accepts()`` tries each terminal on a copy of the parser (exact, unlike
        the LALR table's merged lookaheads) but takes about a millisecond; the answer
        depends only on the state stack, so it is kept per stack.
        """
        parser = error.interactive_parser
        key = tuple(parser.parser_state.state_stack)
        if key not in self._accepts:
            # lark leaves accepts() unannotated; it returns the set of terminal names.
            self._accepts[key] = frozenset(parser.accepts())  # type: ignore[no-untyped-call]
        return self._accepts[key]

    def title_at(self, text: str, line_start: int, line: int) -> Token | None:
        """The section title that starts the line, as the lexer would have read it."""
        match = self.title_line.match(text, line_start)
        if match is None:
            return None
        name = match.lastgroup
        assert name is not None  # every alternative of the pattern is a named group
        start, end = match.span(name)
        column = start - line_start + 1
        return Token(name, match.group(name), start, line, column, line,
                     column + end - start, end)

    def next_title(self, text: str, pos: int) -> int:
        """The start of the first line at or after ``pos`` that holds a section title."""
        while pos < len(text) and not self.title_line.match(text, pos):
            pos = text.index("\n", pos) + 1
        return pos


def _reader() -> _Reader:
    """This thread's reader. Threads do not share one: its builder holds the name of the
    file being read (the language server parses on two threads beside its message loop,
    and a small file must not wait for a megabyte one); one is made from lark's cache in
    some 20 ms."""
    reader: _Reader | None = getattr(_READERS, "reader", None)
    if reader is None:
        reader = _READERS.reader = _Reader()
    return reader


def parse(source: SourceText) -> tuple[ast.Module, list[Diagnostic]]:
    """Read one source file: its AST (every line that could be read) and its syntax errors."""
    text = source.text if source.text.endswith("\n") else source.text + "\n"
    reader = _reader()
    reader.builder.file = source.name
    pieces, diagnostics = _read(reader, text, source.name)
    return ast.Module(source.name, tuple(_sections(pieces, source.name))), diagnostics


def parse_text(text: str, name: str = "<string>") -> tuple[ast.Module, list[Diagnostic]]:
    """``parse`` for text held in memory (tests, editors)."""
    return parse(from_string(name, text))


def _read(reader: _Reader, text: str, file: str) -> tuple[list[Piece], list[Diagnostic]]:
    """The file as a flat list (title tokens, each followed by its section's nodes)."""
    pieces: list[Piece] = []
    diagnostics: list[Diagnostic] = []
    pos, section = 0, None
    lines = LineCounter("\n")  # type: ignore[no-untyped-call]  # (lark: untyped); at ``pos``
    while pos < len(text):
        rule = _START_RULES[section]
        try:
            pieces += reader.parse(text, pos, len(text), rule, lines)
            break
        except UnexpectedInput as error:
            failure = error
        where = min(max(failure.pos_in_stream or 0, pos), len(text) - 1)
        line = failure.line if isinstance(failure.line, int) and failure.line > 0 else (
            lines.line + text.count("\n", pos, where))
        line_start = text.rfind("\n", 0, where) + 1
        if line_start > pos:
            done = reader.parse(text, pos, line_start, rule, lines)
            pieces += done
            section = _last_section(done, section)
        title = reader.title_at(text, line_start, line)
        if title is not None:
            pieces.append(title)
            section = _TITLES[title.type][0]
        diagnosis = diagnose(text, where, line, reader.expected(failure), reader.keywords,
                             file, section)
        diagnostics.append(diagnosis.diagnostic)
        next_pos = text.index("\n", where) + 1
        if diagnosis.skip_to_title:
            next_pos, section = reader.next_title(text, next_pos), None
        # A plain string, not a TextSlice: lark's LineCounter adds a slice's ``rindex``
        # (an index into the whole text) to its own position, which put every line after
        # the second failing one at a negative column.
        lines.feed(text[pos:next_pos])
        pos = next_pos
    return pieces, diagnostics


def _last_section(pieces: list[Piece], section: ast.SectionKind | None) -> ast.SectionKind | None:
    """The section open at the end of ``pieces`` (``section`` if they hold no title)."""
    for piece in reversed(pieces):
        if isinstance(piece, Token):
            return _TITLES[piece.type][0]
    return section


def _sections(pieces: list[Piece], file: str) -> list[ast.Section]:
    """Group the flat list into sections: the grammar puts a title before any node."""
    sections: list[ast.Section] = []
    title: Token | None = None
    body: list[SectionItem] = []
    for piece in [*pieces, None]:
        if piece is not None and not isinstance(piece, Token):
            body.append(piece)
            continue
        if title is not None and title.type in _TITLES:
            line, column, end = title.line, title.column, title.end_column
            assert line is not None and column is not None and end is not None
            span = Span(file, line, column, end - column)
            sections.append(_TITLES[title.type][1](tuple(body), span))
        title, body = piece, []
    return sections
