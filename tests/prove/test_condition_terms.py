"""The prover's translation of a condition (``prove.engine.condition``) against the
concrete evaluator (``observe.condition.holds``): on random trees and random states,
the z3 term, with every operand fixed to its value, simplifies to what the evaluator
computes; and a state a solver finds for the term is one the evaluator accepts."""

from __future__ import annotations

import z3
from condition_strategies import OPERANDS, conditions, states
from hypothesis import given, settings

from asictl.il import ast
from asictl.observe.condition import Expr, holds, parse_expression
from asictl.observe.operands import Operand
from asictl.prove.engine import condition


@settings(max_examples=300, deadline=None)
@given(conditions(), states())
def test_the_z3_term_agrees_with_the_evaluator_on_any_state(expr: Expr,
                                                            state: dict[Operand, int]):
    by_node = {operand.node: value for operand, value in state.items()}

    def read(node: ast.Operand) -> z3.BitVecRef:
        return z3.BitVecVal(by_node[node], 32)

    term = z3.simplify(condition(expr, read))
    assert z3.is_true(term) or z3.is_false(term)
    assert z3.is_true(term) == holds(expr, state.__getitem__)


@settings(max_examples=100, deadline=None)
@given(conditions())
def test_a_model_of_the_term_is_a_state_the_evaluator_accepts(expr: Expr):
    cells = {operand.node: z3.BitVec(f"v{i}", 32) for i, operand in enumerate(OPERANDS.values())}
    solver = z3.Solver()
    for operand in OPERANDS.values():
        solver.add(z3.ULE(cells[operand.node], operand.maximum))
    solver.add(condition(expr, cells.__getitem__))
    if solver.check() == z3.sat:
        model = solver.model()
        state = {operand: model.eval(cells[operand.node], model_completion=True).as_long()
                 for operand in OPERANDS.values()}
        assert holds(expr, state.__getitem__)


def test_durations_compare_with_the_timers_milliseconds():
    expr = parse_expression("TV 1 >= 2s and TV 1 < 2010ms")
    timer = OPERANDS["TV 1"]
    for ms, expected in ((1990, False), (2000, True), (2010, False)):
        assert holds(expr, {timer: ms}.__getitem__) is expected
        term = condition(expr, lambda node, ms=ms: z3.BitVecVal(ms, 32))
        assert z3.is_true(z3.simplify(term)) is expected
