"""The lean parser reads exactly what lark's own lexer and parser loop would.

``asictl.il.parser`` reads with ``LeanParser``; the oracle here is lark's
``ContextualLexer`` and ``ParserState`` driven by lark's ``parse_from_state`` on the same
parse table. Both must make the same tokens (type, text and every position), the same AST
and the same syntax errors, on valid programs, on broken ones and on noise.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from copy import copy
from pathlib import Path
from typing import Any

import lark.lexer
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from il_strategies import modules
from lark import Token
from lark.lexer import LexerState, LexerThread, LineCounter
from lark.parsers.lalr_parser_state import ParseConf, ParserState
from lark.utils import TextSlice

from asictl.il import lean_parser, parser
from asictl.il.lean_parser import lean_actions

ROOT = Path(__file__).resolve().parents[2]
SAME = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def read(text: str, lean: bool, monkeypatch: pytest.MonkeyPatch) -> tuple[Any, ...]:
    """Tokens, AST and diagnostics of ``text``, read the lean way or lark's way.

    The tokens are every token the lean parser makes, or lark's lexer passes to lark's
    parser, in order (their facts read after the parse, as a callback may change them).
    """
    made: list[Token] = []

    def recorded(*args: Any) -> Token:
        token = Token(*args)
        made.append(token)
        return token

    class Recording(lark.lexer.Lexer):
        def __init__(self, lexer: lark.lexer.Lexer) -> None:
            self.lexer = lexer

        def lex(self, lexer_state: LexerState, parser_state: Any) -> Iterator[Token]:
            for token in self.lexer.lex(lexer_state, parser_state):
                made.append(token)
                yield token

    def parse(self: Any, text: str, start: int, end: int, rule: str,
              lines: LineCounter) -> list[Any]:
        state = LexerState(TextSlice(text, start, end), copy(lines))
        if lean:
            return list(self.parser.parse(state, rule))
        frontend = self.lark.parser
        conf = ParseConf(frontend.parser.parser.parse_table, frontend.parser.parser.callbacks,
                         rule)
        thread = LexerThread(Recording(frontend.lexer), state)
        return list(frontend.parser.parser.parse_from_state(ParserState(conf, thread)))

    with monkeypatch.context() as patch:
        patch.setattr(parser._Reader, "parse", parse)
        if lean:
            patch.setattr(lean_parser, "Token", recorded)
        module, diagnostics = parser.parse_text(text, "t.asi")
    tokens = [(t.type, t.value, t.start_pos, t.line, t.column, t.end_line, t.end_column,
               t.end_pos) for t in made]
    return tokens, module, diagnostics


def assert_same(text: str, monkeypatch: pytest.MonkeyPatch) -> None:
    lean = read(text, True, monkeypatch)
    plain = read(text, False, monkeypatch)
    assert lean[0] == plain[0]
    assert lean[1] == plain[1]
    assert lean[2] == plain[2]


SOURCES = sorted(
    p for p in ROOT.rglob("*") if p.suffix in (".asi", ".fb") and ".git" not in p.parts
)


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_the_sources_of_the_project(path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    assert_same(path.read_text(encoding="latin-1"), monkeypatch)


def test_a_long_program(monkeypatch: pytest.MonkeyPatch) -> None:
    text = "[DECL]\nBuffer BYTE 4\n[PROGRAM]\n" + "".join(
        f"    A I {n % 31 + 1}.{n % 4} ; network {n}\n    AN F {n % 128}.{n % 8}\n"
        f"    = Q {n % 31 + 1}.2\n***\n\n    L KB {n % 256}\n    T Buffer {n % 4}\n"
        f"l{n}: JC = l{n}\n"
        for n in range(300)
    ) + "    BE\n"
    tokens, _, diagnostics = read(text, True, monkeypatch)
    assert len(tokens) > 5000 and diagnostics == []
    assert_same(text, monkeypatch)


@pytest.mark.parametrize("text", [
    "[PROGRAM]\n    A Zähler 1.0\n    = Q 1.0\n",  # a character no terminal takes
    "[PROGRAM]\n    A\n    L   ; load\n    JC\n    BE\n",  # tokens a state cannot take
    "[SETUP]\n1: iiox 1 2\n[DECL]\nA BYTE 1\nx FB\n[PROGRAM]\n  JU = A\n",  # reserved words
    "text before a title\n[NOSUCH]\n[PROGRAM]\n    A I 1.0 junk\n[END]\nanything",
    "[PROGRAM]\n    A I 1.0",  # no line end at the end
    "",
])
def test_syntax_errors(text: str, monkeypatch: pytest.MonkeyPatch) -> None:
    tokens, _, diagnostics = read(text, True, monkeypatch)
    assert text == "" or diagnostics or tokens
    assert_same(text, monkeypatch)


WORDS = st.sampled_from([
    "[PROGRAM]", "[SETUP]", "[DECL]", "[GATING]", "[OPTIONS]", "[ASM]", "[RAW]", "[END]",
    "PROGRAM", "A", "AN", "O", "=", "S", "R", "N", "L", "T", "+", "><", ">=", "F", "CU",
    "C", "***", "BE", "BEC", "JU", "JC", "FB", "PARAM", "ASM", "I", "I2", "Q", "IB", "FY",
    "KT", "KP", "BYTE", "TIMER", "and", "not", "yes", "iiio", "x", "end:", ":", ".", ",",
    ";", "4", "4.0", "0Ah", "1234567890", ":00000001FF", "ä", " ", "\t", "\n", "\n",
])


@SAME
@given(st.lists(WORDS, max_size=40).map(" ".join))
def test_word_soup(text: str) -> None:
    with pytest.MonkeyPatch.context() as monkeypatch:
        assert_same(text, monkeypatch)


@settings(SAME, max_examples=40)
@given(modules(), st.data())
def test_programs_and_their_mutations(module: Any, data: st.DataObject) -> None:
    programs_and_their_mutations(module, data)


@pytest.mark.slow
@settings(SAME, max_examples=600)
@given(modules(), st.data())
def test_programs_and_their_mutations_long(module: Any, data: st.DataObject) -> None:
    programs_and_their_mutations(module, data)


def programs_and_their_mutations(module: Any, data: st.DataObject) -> None:
    text = module.to_source()
    with pytest.MonkeyPatch.context() as monkeypatch:
        assert_same(text, monkeypatch)
        i = data.draw(st.integers(0, max(len(text) - 1, 0)))
        mutated = text[:i] + data.draw(st.sampled_from(["", " ", "\n", "x", "1", ".", "ä"]))
        assert_same(mutated + text[i + 1:], monkeypatch)


def test_lean_actions_refuse_terminal_callbacks() -> None:
    table = parser._reader().parser.parser.parse_table
    with pytest.raises(ValueError, match="terminal callbacks"):
        lean_actions(table, {"NAME": lambda children: children})  # type: ignore[dict-item]


def test_threads_parse_at_once_each_with_its_own_reader():
    """The language server parses on two threads: each gets what one thread alone gets."""
    texts = ["[PROGRAM]\n" + "".join(f" A F {n}.{k % 8}\n x{k}\n" for k in range(300))
             for n in range(4)]
    alone = [parser.parse_text(text, f"/t{n}.asi") for n, text in enumerate(texts)]
    found: dict[int, object] = {}

    def work(n: int) -> None:
        for _ in range(3):
            found[n] = parser.parse_text(texts[n], f"/t{n}.asi")

    threads = [threading.Thread(target=work, args=(n,)) for n in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert [found[n] for n in range(4)] == alone
    assert all(d.span.file == f"/t{n}.asi" for n, (_, ds) in enumerate(alone) for d in ds)
