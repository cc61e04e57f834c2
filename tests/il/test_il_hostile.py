"""Whatever the input, reading it yields an AST and diagnostics, never an exception."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from il_strategies import modules

from asictl.build import check as check_program
from asictl.codes import SyntaxCode
from asictl.il.parser import parse
from asictl.source import SourceText, from_bytes, from_string

HOSTILE = settings(max_examples=200, deadline=None,
                   suppress_health_check=[HealthCheck.too_slow])

#: Fragments of IL, to reach deep into the grammar more often than random text does.
WORDS = st.sampled_from([
    "[PROGRAM]", "[SETUP]", "[DECL]", "[GATING]", "[OPTIONS]", "[ASM]", "[RAW]", "[END]",
    "PROGRAM", "END", "A", "AN", "O", "ON", "=", "S", "R", "N", "L", "T", "+", "-", "!=", "><",
    ">", ">=", "<", "<=", "F", "CU", "CD", "STP", "C", "***", "BE", "BEC", "BEU", "JU", "JC",
    "FB", "PARAM", "ASM", "I", "I2", "Q", "IB", "I2B", "QB", "FY", "FW", "PSeg", "KT", "KC",
    "KP", "KB", "KW", "BYTE", "TIMER", "COUNTER", "and", "or", "not", "yes", "iiio", "x",
    "end:", ":", ".", ",", ";", "4", "4.0", "0Ah", "1234567890", ":00000001FF", "ä", "\x00",
    " ", "\t", "\n", "\n", "\n",
])


def check(text: str) -> None:
    source = from_string("<string>", text)
    _, diagnostics = parse(source)
    assert_sane(source, diagnostics)


def assert_sane(source: SourceText, diagnostics: list) -> None:
    """Errors only, with known codes, in reading order, at places that exist."""
    lines = source.text.split("\n")
    for d in diagnostics:
        assert d.is_error and d.code in set(SyntaxCode)
        assert d.span.file == source.name
        assert 1 <= d.span.line <= len(lines)
        assert 1 <= d.span.column <= len(lines[d.span.line - 1]) + 1
    assert [d.span.line for d in diagnostics] == sorted(d.span.line for d in diagnostics)


@HOSTILE
@given(st.text())
def test_arbitrary_text(text: str) -> None:
    check(text)


@HOSTILE
@given(st.lists(WORDS, max_size=40).map(" ".join))
def test_il_word_soup(text: str) -> None:
    check(text)


@HOSTILE
@given(st.binary())
def test_arbitrary_bytes(raw: bytes) -> None:
    source = from_bytes("bin.asi", raw)
    _, diagnostics = parse(source)
    assert_sane(source, diagnostics)


@st.composite
def mutated_programs(draw: st.DrawFn) -> str:
    """A valid program with a few characters deleted, duplicated, swapped or replaced."""
    text = draw(modules()).to_source()
    for _ in range(draw(st.integers(1, 5))):
        if len(text) < 2:
            break
        i = draw(st.integers(0, len(text) - 2))
        edit = draw(st.sampled_from(["delete", "duplicate", "swap", "replace"]))
        if edit == "delete":
            text = text[:i] + text[i + 1:]
        elif edit == "duplicate":
            text = text[:i] + text[i] + text[i:]
        elif edit == "swap":
            text = text[:i] + text[i + 1] + text[i] + text[i + 2:]
        else:
            text = text[:i] + draw(st.characters(codec="latin-1")) + text[i + 1:]
    return text


@settings(HOSTILE, max_examples=50)
@given(mutated_programs())
def test_mutated_programs(text: str) -> None:
    check(text)


@pytest.mark.slow
@settings(HOSTILE, max_examples=500)
@given(mutated_programs())
def test_mutated_programs_long(text: str) -> None:
    check(text)


def assert_inside(source: SourceText, diagnostics: list) -> None:
    """Every diagnostic, of any stage, at a line and column the file has."""
    lines = source.text.split("\n")
    for d in diagnostics:
        if d.span is None or d.span.file != source.name:
            continue
        assert 1 <= d.span.line <= len(lines), d
        assert 1 <= d.span.column <= len(lines[d.span.line - 1]) + 1, d


def test_lines_after_two_failing_lines_keep_their_columns() -> None:
    """Two lines in a row that fail to parse once put later places at column -15."""
    source = from_string("m5.asi", "[PROGRAM]\nU I 1.1\nLD KT 100\nA M 1.0\n")
    diagnostics = check_program(source).diagnostics
    assert_inside(source, diagnostics)
    assert [(d.span.line, d.span.column) for d in diagnostics if d.span.line == 4] == [(4, 3)]


#: Whole lines of a program, good and bad, so that failures follow failures.
PROGRAM_LINES = st.sampled_from([
    "A I 1.0", "= Q 2.0", "U I 1.1", "LD KT 100", "A M 1.0", "L KT 500", "S T 1", "x y z",
    "AN F 10.7", "JC = end", "end: BE", "   ", "; comment", "A I 99.9", "O Reading 3.2", "***",
])


@HOSTILE
@given(st.lists(PROGRAM_LINES, max_size=12))
def test_every_diagnostic_of_a_check_lies_inside_the_file(lines: list[str]) -> None:
    source = from_string("p.asi", "[PROGRAM]\n" + "\n".join(lines) + "\n")
    assert_inside(source, check_program(source).diagnostics)
