"""lark's contextual lexer and LALR parser loop in one lean loop, for long programs.

A 10,000-line program is some 45,000 tokens, 17,000 ignored blanks and 54,000
reductions. lark spends several Python calls on each token (the lexer generator, the
state's lexer, its scanner, the token's two constructors, the line counter, the parser's
``feed_token``) and looks up each reduction's callback in a dictionary keyed by rule
objects, whose hash and equality are Python methods. ``LeanParser`` reads the same
tokens with the very scanners, ignore lists and callbacks lark built for each parser
state, counts lines as lark's ``LineCounter`` does, and drives lark's parse table with
each reduction's size, callback and left side looked up once.

It only ever takes the plain path. Where a text does not scan, and at the end of the
input, it hands the parser state to lark's own loop (``parse_from_state``), which then
raises the error it always raises there or feeds the end of input; where a token has no
action, lark's ``feed_token`` raises the error from the same state. So every error, its
expected terminals and its interactive parser are lark's. ``tests/il/test_lean_parser.py``
holds this loop to lark's tokens, ASTs and errors.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

from lark import Token
from lark.common import ParserCallbacks
from lark.exceptions import UnexpectedInput
from lark.lexer import BasicLexer, ContextualLexer, LexerState, LexerThread
from lark.parsers.lalr_analysis import ParseTableBase, Shift
from lark.parsers.lalr_interactive_parser import InteractiveParser
from lark.parsers.lalr_parser import _Parser
from lark.parsers.lalr_parser_state import ParseConf, ParserState

#: A state's action on a symbol: ``(True, next state)`` to shift (or to go to, after a
#: reduction), ``(False, (size, callback, left side))`` to reduce.
Action = tuple[bool, Any]
Actions = dict[int, dict[str, Action]]


def lean_actions(parse_table: ParseTableBase[int], callbacks: ParserCallbacks) -> Actions:
    """The parse table with each reduction's size, callback and left side looked up.

    Raises ``ValueError`` if a terminal has a callback of its own (a shifted token would
    then need one; this grammar's builder has none).
    """
    if any(isinstance(key, str) for key in callbacks):
        raise ValueError("terminal callbacks are not supported")
    actions: Actions = {}
    for state, by_symbol in parse_table.states.items():
        row: dict[str, Action] = {}
        for symbol, (action, arg) in by_symbol.items():
            if action is Shift:
                row[symbol] = (True, arg)
            else:
                row[symbol] = (False, (len(arg.expansion), callbacks[arg], arg.origin.name))
        actions[state] = row
    return actions


class _StateLexer(NamedTuple):
    """What lexing in one parser state needs, taken from lark's lexer for that state."""

    match: Callable[[Any, int], tuple[str, str] | None]
    ignore: frozenset[str]
    newline: frozenset[str]
    callbacks: dict[str, Callable[[Token], Token]]


class LeanParser:
    """Parses as lark's LALR parser with its contextual lexer does (see the module's doc)."""

    def __init__(self, parser: _Parser, lexer: ContextualLexer) -> None:
        self.parser = parser
        self.lexer = lexer
        self.actions = lean_actions(parser.parse_table, parser.callbacks)
        self._lexers: dict[int, _StateLexer] = {}

    def _state_lexer(self, state: int) -> _StateLexer:
        lexer = self.lexer.lexers[state]
        assert isinstance(lexer, BasicLexer)
        scanner = lexer.scanner  # built on first use, with lexer.callback
        found = _StateLexer(scanner.match, lexer.ignore_types, lexer.newline_types,
                            lexer.callback)
        self._lexers[state] = found
        return found

    def parse(self, lexer_state: LexerState, start: str) -> Any:
        """What lark's ``parse`` with ``start`` returns for the lexer state's text."""
        conf = ParseConf(self.parser.parse_table, self.parser.callbacks, start)
        state = ParserState(conf, LexerThread(self.lexer, lexer_state))
        token = self._run(state, lexer_state)
        return self.parser.parse_from_state(state, last_token=token)

    def _run(self, state: ParserState[int], lexer_state: LexerState) -> Token | None:
        """Lex and parse as far as the plain path goes; the last token read."""
        actions = self.actions
        lexers = self._lexers
        state_stack = state.state_stack
        value_stack = state.value_stack
        text = lexer_state.text
        end = text.end
        lines = lexer_state.line_ctr
        token = None
        while lines.char_pos < end:
            found = lexers.get(state_stack[-1]) or self._state_lexer(state_stack[-1])
            start = lines.char_pos
            scanned = found.match(text, start)
            if scanned is None:  # lark's loop raises its error from here
                return token
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
            new = Token(kind, value, start, line, column, lines.line, lines.column,
                        lines.char_pos)
            if callback is not None:
                new = callback(new)
            if ignored:
                continue
            token = lexer_state.last_token = new
            kind = token.type
            while True:
                action = actions[state_stack[-1]].get(kind)
                if action is None:
                    self._feed_as_lark(state, token)
                    break
                shift, arg = action
                if shift:
                    state_stack.append(arg)
                    value_stack.append(token)
                    break
                size, reduce, left = arg
                if size:
                    children = value_stack[-size:]
                    del state_stack[-size:]
                    del value_stack[-size:]
                else:
                    children = []
                value_stack.append(reduce(children))
                state_stack.append(actions[state_stack[-1]][left][1])
        return token

    def _feed_as_lark(self, state: ParserState[int], token: Token) -> None:
        """lark's ``feed_token``, and its error as lark's parse loop raises it."""
        try:
            state.feed_token(token)
        except UnexpectedInput as error:
            error.interactive_parser = InteractiveParser(self.parser, state, state.lexer)
            raise
