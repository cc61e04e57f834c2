"""The grammar itself: conflict-free, and every rule and terminal accounted for in Python."""

from __future__ import annotations

import re

import pytest
from lark import Lark

from asictl.il.parser import RESERVED, _reader, grammar_text, lark_options
from asictl.il.syntax_errors import MARK_WORDS, describe
from asictl.il.transformer import AstBuilder


def test_grammar_strict() -> None:
    """strict=True makes lark fail on any LALR conflict and on any two terminals of one
    lexer state that could match the same text at the same priority (via interegular)."""
    Lark(grammar_text(), strict=True, **lark_options())


def handled_rules() -> set[str]:
    return {name for name in vars(AstBuilder) if not name.startswith("_")}


def test_every_rule_has_a_handler_and_every_handler_a_rule() -> None:
    rules = {r.alias or r.origin.name for r in _reader().lark.rules}
    built = {str(name) for name in rules if not str(name).startswith("_")}
    assert built == handled_rules()


def test_reserved_words_are_the_grammar_keywords_and_marks() -> None:
    terminals = _reader().lark.terminals
    keywords = {t.pattern.value.upper() for t in terminals
                if t.pattern.type == "str" and t.pattern.value.isalpha()}
    marks = {t.name for t in terminals if t.name.endswith("_MARK")}
    assert marks == set(MARK_WORDS)
    for name in marks:
        regexp = _reader().lark.get_terminal(name).pattern.to_regexp()
        assert re.fullmatch(regexp, MARK_WORDS[name]), name
    assert keywords | {word.upper() for word in MARK_WORDS.values()} == RESERVED


def test_every_parser_state_can_be_described() -> None:
    """An error can happen in any state: each one's expectations read as words."""
    reader = _reader()
    states = reader.lark.parser.parser.parser.parse_table.states
    for actions in states.values():
        expected = frozenset(t for t in actions if t.isupper())
        text = describe(expected, reader.keywords)
        assert not re.search(r"[A-Z0-9]_|_[A-Z]|\$", text), (expected, text)


@pytest.mark.parametrize(
    ("expected", "text"),
    [
        (frozenset({"_NL"}), "end of line"),
        (frozenset({"AND", "OR", "_NL"}), "'and', 'or' or end of line"),
        (frozenset({"PROGRAM_TITLE", "$END"}), "a section title"),
    ],
)
def test_describe(expected: frozenset[str], text: str) -> None:
    assert describe(expected, _reader().keywords) == text
