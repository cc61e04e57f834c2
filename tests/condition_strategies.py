"""Hypothesis strategies for conditions (``asictl.observe.condition``): trees built
directly, not texts, so that printing and reading back can be checked against them, and
the concrete evaluator against the prover's translation."""

from __future__ import annotations

from hypothesis import strategies as st

from asictl.observe.condition import (
    Comparison,
    Connective,
    Duration,
    Expr,
    Negation,
    Number,
    Ref,
    Truth,
)
from asictl.observe.operands import Operand, parse_operand

#: Operands with their largest value: bits, a slave's data bits, bytes, a count, a time.
BITS = ("I 1.0", "Q 2.1", "F 3.7", "T 1", "C 0")
VALUES = ("I 1", "QB 16", "FY 2", "CV 0", "TV 1")
OPERANDS: dict[str, Operand] = {text: parse_operand(text) for text in (*BITS, *VALUES)}
COMPARE = ("==", "!=", "<", "<=", ">", ">=")


def _ref(text: str) -> Ref:
    return Ref(text, OPERANDS[text])


def values() -> st.SearchStrategy[Expr]:
    return st.one_of(st.sampled_from(VALUES + BITS).map(_ref),
                     st.integers(0, 0xFFFF_FFFF).map(Number))


def comparisons() -> st.SearchStrategy[Expr]:
    timer = st.builds(Comparison, st.sampled_from(COMPARE), st.just(_ref("TV 1")),
                      st.integers(0, 50_000).map(Duration))
    return st.one_of(st.builds(Comparison, st.sampled_from(COMPARE), values(), values()),
                     timer)


def conditions() -> st.SearchStrategy[Expr]:
    leaves = st.one_of(st.sampled_from(BITS).map(_ref), st.booleans().map(Truth),
                       comparisons())
    return st.recursive(leaves, lambda inner: st.one_of(
        st.builds(Negation, inner),
        st.builds(Connective, st.sampled_from(("and", "or", "xor")),
                  st.lists(inner, min_size=2, max_size=4).map(tuple)),
        st.builds(Comparison, st.sampled_from(("==", "!=")), inner, inner),
    ), max_leaves=12)


def states() -> st.SearchStrategy[dict[Operand, int]]:
    """A value for every operand, within its range."""
    return st.fixed_dictionaries({operand: st.integers(0, operand.maximum)
                                  for operand in OPERANDS.values()})
