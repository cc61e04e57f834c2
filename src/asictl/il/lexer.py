"""lark's contextual lexer with less Python work per token, for long programs.

A 10,000-line program is some 45,000 tokens and 17,000 ignored blanks; lark's lexer spends
several calls on each (lexer lookup, ``next_token``, the scanner's ``match``, the token's
``__new__`` and ``_future_new``, the line counter's ``feed``). This lexer reads the same
tokens in one loop: it scans with the very scanners, ignore lists and callbacks lark
built for each parser state, and counts lines as lark's ``LineCounter`` does.

Where the text does not scan (a syntax error), it hands the position back to lark's own
lexer, which raises what it always raises there; so errors, their expected terminals and
what the parser does with them stay lark's. ``tests/il/test_lexer.py`` holds both lexers
to the same tokens and errors.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any, NamedTuple

from lark import Token
from lark.lexer import BasicLexer, ContextualLexer, Lexer, LexerState, Scanner
from lark.utils import TextSlice


class _StateLexer(NamedTuple):
    """What scanning in one parser state needs, taken from lark's lexer for that state."""

    match: Callable[[TextSlice[str], int], tuple[str, str] | None]
    ignore: frozenset[str]
    newline: frozenset[str]
    callbacks: dict[str, Callable[[Token], Token]]


class LeanContextualLexer(Lexer):
    """Reads the tokens lark's ``ContextualLexer`` would, faster (see the module's doc).

    Pass it to ``lark.lexer.LexerThread`` in place of the contextual lexer.
    """

    def __init__(self, contextual: ContextualLexer) -> None:
        self.contextual = contextual
        self._states: dict[int, _StateLexer] = {}

    def _state_lexer(self, state: int) -> _StateLexer:
        lexer = self.contextual.lexers[state]
        assert isinstance(lexer, BasicLexer)
        scanner: Scanner = lexer.scanner  # builds lexer.callback too
        found = _StateLexer(scanner.match, lexer.ignore_types, lexer.newline_types,
                            lexer.callback)
        self._states[state] = found
        return found

    def lex(self, lexer_state: LexerState, parser_state: Any) -> Iterator[Token]:
        """The tokens from the lexer state's position, each lexed in the parser's state."""
        text = lexer_state.text
        end = text.end
        lines = lexer_state.line_ctr
        states = self._states
        stack: list[int] = parser_state.state_stack
        while lines.char_pos < end:
            position = stack[-1]
            found = states.get(position) or self._state_lexer(position)
            start = lines.char_pos
            scanned = found.match(text, start)
            if scanned is None:  # lark's lexer raises its error here
                yield from self.contextual.lex(lexer_state, parser_state)
                return
            value, kind = scanned
            line, column = lines.line, lines.column
            if kind in found.newline:
                newlines = value.count("\n")
                if newlines:
                    lines.line += newlines
                    lines.line_start_pos = start + value.rindex("\n") + 1
            lines.char_pos = start + len(value)
            lines.column = lines.char_pos - lines.line_start_pos + 1
            ignored = kind in found.ignore
            callback = found.callbacks.get(kind)
            if ignored and callback is None:
                continue
            token = Token(kind, value, start, line, column, lines.line, lines.column,
                          lines.char_pos)
            if callback is not None:
                token = callback(token)
            if not ignored:
                lexer_state.last_token = token
                yield token
