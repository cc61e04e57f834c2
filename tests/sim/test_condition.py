"""Conditions (plant rules' ``when``, ``run_until``): random expressions against Python's
own evaluation of the same text, comparisons, and errors instead of crashes."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from asictl.observe.operands import parse_operand
from asictl.sim.condition import parse_condition

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


@pytest.mark.parametrize(("text", "message"), [
    ("Q 2.0 and", "ends too early"),
    ("and Q 2.0", "an operand expected before 'and'"),
    ("Q 2.0 == x", "is not a number"),
    ("Q 2.0 Q 2.1", "is not an operand"),
    ("(Q 2.0 or F 0.0", "ends too early"),
    ("(Q 2.0 or F 0.0 (", "')' expected"),
    ("(" * 40 + "Q 2.0" + ")" * 40, "nested more than 32 deep"),
    ("not " * 40 + "Q 2.0", "nested more than 32 deep"),
])
def test_bad_conditions_say_what_is_wrong(text: str, message: str):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        parse_condition(text)
