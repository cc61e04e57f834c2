"""lark's LALR parser loop with less Python work per token, for long programs.

lark's ``ParserState.feed_token`` looks up, for every reduction, the rule's callback in a
dictionary keyed by rule objects (whose hash and equality are Python methods), its size
and the name of its left side. ``LeanParserState`` takes all of that from a table made
once from lark's own parse table and callbacks, and otherwise does what lark does.

Whenever its table does not answer (a token the state cannot take, the end of input, or
a parser copy whose callbacks lark swapped, as ``accepts()`` does), it hands the same
state to lark's ``feed_token``, so errors and everything after them are lark's.
``tests/il/test_lean_lark.py`` holds both parsers to the same results and errors.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from lark import Token
from lark.common import ParserCallbacks
from lark.parsers.lalr_analysis import ParseTableBase, Shift
from lark.parsers.lalr_parser_state import ParseConf, ParserState

#: One action of a state on a symbol: ``(True, next state)`` to shift (or to go to, after
#: a reduction), ``(False, (size, callback, left side))`` to reduce.
Reduction = tuple[int, Callable[[list[Any]], Any], str]
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


class LeanParseConf(ParseConf[int]):
    """lark's parse configuration, with the table of ``lean_actions`` for its callbacks."""

    def __init__(self, parse_table: ParseTableBase[int], callbacks: ParserCallbacks,
                 start: str, actions: Actions) -> None:
        super().__init__(parse_table, callbacks, start)
        self.actions = actions
        self.actions_for = callbacks


class LeanParserState(ParserState[int]):
    """A parser state whose ``feed_token`` uses a ``LeanParseConf``'s table."""

    def feed_token(self, token: Token, is_end: bool = False) -> Any:
        conf = self.parse_conf
        if is_end or not isinstance(conf, LeanParseConf) or conf.callbacks is not conf.actions_for:
            return super().feed_token(token, is_end)
        actions = conf.actions
        state_stack = self.state_stack
        value_stack = self.value_stack
        kind = token.type
        while True:
            action = actions[state_stack[-1]].get(kind)
            if action is None:  # lark raises its error
                return super().feed_token(token)
            shift, arg = action
            if shift:
                state_stack.append(arg)
                value_stack.append(token)
                return None
            size, callback, left = arg
            if size:
                children = value_stack[-size:]
                del state_stack[-size:]
                del value_stack[-size:]
            else:
                children = []
            value_stack.append(callback(children))
            state_stack.append(actions[state_stack[-1]][left][1])
