"""Conditions (plant rules' ``when``, ``run_until``): random expressions against Python's
own evaluation of the same text, comparisons, and errors instead of crashes."""

from __future__ import annotations

import itertools
from pathlib import Path

import lark
import pytest
from condition_strategies import conditions, states
from hypothesis import given, settings
from hypothesis import strategies as st

import asictl
from asictl.observe.condition import (
    Comparison,
    ConditionError,
    Connective,
    Expr,
    Negation,
    holds,
    is_condition,
    parse_condition,
    parse_expression,
    show,
)
from asictl.observe.operands import Operand, parse_operand

NAMES = {"Q 2.0": "a", "I 1.1": "b", "F 3.7": "c"}


def expressions() -> st.SearchStrategy[str]:
    leaf = st.sampled_from(sorted(NAMES))
    return st.recursive(leaf, lambda inner: st.one_of(
        st.builds(lambda x: f"not {x}", inner),
        st.builds(lambda x, y: f"{x} and {y}", inner, inner),
        st.builds(lambda x, y: f"{x} or {y}", inner, inner),
        st.builds(lambda x: f"({x})", inner),
    ), max_leaves=8)


@settings(max_examples=150, deadline=None)
@given(expressions())
def test_random_conditions_agree_with_python(text: str):
    condition = parse_condition(text)
    python = text
    for operand, name in NAMES.items():
        python = python.replace(operand, name)
    for values in itertools.product((0, 1), repeat=3):
        env = dict(zip(sorted(NAMES.values()), values, strict=True))
        by_text = {op: env[name] for op, name in NAMES.items()}
        assert condition(lambda o, v=by_text: v[str(o)]) == bool(eval(python, {}, env))


def test_comparisons_and_symbols():
    condition = parse_condition("CV 0 >= 3 and QB 16 != 0x08", None)
    values = {"CV 0": 3, "QB 16": 7}
    assert condition(lambda o: values[str(o)])
    values["CV 0"] = 2
    assert not condition(lambda o: values[str(o)])
    assert [str(o) for o in condition.operands] == ["CV 0", "QB 16"]
    assert parse_operand("Q 2.0") in parse_condition("not (Q 2.0)").operands


@pytest.mark.parametrize(("text", "message", "offset"), [
    ("Q 2.0 and", "expected an operand, a number or '(', found the end", 9),
    ("and Q 2.0", "expected an operand, a number or '(', found 'and'", 0),
    ("Q 2.0 == x", "'x' is not an operand", 9),
    ("Q 2.0 Q 2.1", "'Q 2.0 Q 2.1' is not an operand", 0),
    ("(Q 2.0 or F 0.0", "expected and, or, xor or ')', found the end", 15),
    ("(Q 2.0 or F 0.0 (", "expected and, or, xor, a comparison or ')', found '('", 16),
    ("Q 2.0 not F 0.0", "expected and, or, xor, a comparison or the end, found 'not'", 6),
    ("CV 0 < 1 < 2", "comparisons do not chain", 9),
    ("QB 16", "a condition is true or false: compare the value QB 16", 0),
    ("QB 16 and Q 2.0", "'and' combines conditions: compare the value QB 16", 0),
    ("not CV 1", "'not' negates a condition, not the value CV 1", 4),
    ("CV 1 >= 2s", "a duration compares with a timer's value (TV n), not CV 1", 8),
    ("TV 1 >= 1.5ms", "a duration in whole milliseconds", 8),
    ("QB 16 == 10h", "'10h' is 10 hours: a number in hex is written 0x10", 9),
    ("Q 2.0 == 0x1_0000_0000", "a number up to 4294967295", 9),
    ("Q 2.0 & F 0.0", "unexpected character '&'", 6),
    ("(" * 40 + "Q 2.0" + ")" * 40, "parentheses nested more than 32 deep", 32),
    ("not " * 40 + "Q 2.0", "'not' nested more than 32 deep", 128),
    (" and ".join(["Q 2.0"] * 1000), "at most 4000 characters", 4000),
])
def test_bad_conditions_say_what_is_wrong_and_where(text: str, message: str, offset: int):
    with pytest.raises(ConditionError) as caught:
        parse_condition(text)
    assert message in caught.value.message
    assert caught.value.offset == offset


@settings(max_examples=300, deadline=None)
@given(conditions())
def test_a_printed_condition_reads_back_as_the_same_tree(expr: Expr):
    text = show(expr)
    assert parse_expression(text) == expr
    assert show(parse_expression(text)) == text


def test_a_single_equals_is_double_and_keywords_take_any_case():
    assert parse_expression("CV 0 = 3") == parse_expression("CV 0 == 3")
    assert parse_expression("I 1.0 AND Not I 1.1 Or TRUE") == parse_expression(
        "I 1.0 and not I 1.1 or true")
    assert show(parse_expression("TV 1 >= 2s")) == "TV 1 >= 2000ms"


@settings(max_examples=200, deadline=None)
@given(conditions(), states())
def test_xor_is_an_odd_count_and_comparisons_of_conditions_compare_truths(
        expr: Expr, state: dict[Operand, int]):
    """The evaluator against the meaning each node has, one level down."""
    read = state.__getitem__
    match expr:
        case Connective(op="xor", parts=parts):
            assert holds(expr, read) == (sum(holds(p, read) for p in parts) % 2 == 1)
        case Comparison(op="==", left=left, right=right) if is_condition(left) and is_condition(
                right):
            assert holds(expr, read) == (holds(left, read) == holds(right, read))
        case Negation(arg=arg):
            assert holds(expr, read) is not holds(arg, read)
        case _:
            assert holds(expr, read) in (True, False)


def test_the_grammar_is_free_of_conflicts():
    """strict=True fails on any LALR conflict and on two terminals of one lexer state that
    could match the same text (interegular): the keywords are re-typed words, not rivals."""
    grammar = (Path(asictl.__file__).parent / "grammar" / "condition.lark").read_text()
    lark.Lark(grammar, parser="lalr", lexer="contextual", strict=True)
