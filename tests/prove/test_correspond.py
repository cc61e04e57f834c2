"""The random run that proposes the pairs of a relational invariant
(``prove/correspond.py``): a renamed flag is paired with its new name, elements that the
run tells apart are not paired, and a difference is told only of programs whose run is
the master's (no firmware answers left out)."""

from __future__ import annotations

import pytest

from asictl.build import build
from asictl.il.loader import Program
from asictl.prove.correspond import Pair, corresponding
from asictl.prove.symbolic import Key, build_cycle
from asictl.source import from_string

pytest.importorskip("z3")

SETUP = "[SETUP]\n1: iiii, 0\n2: oooo, 0\n[PROGRAM]\n"
#: a latch: I 1.0 sets F 0.1, I 1.1 resets it, Q 2.0 shows it
LATCH = SETUP + ("    A I 1.0\n    S F 0.1\n***\n    A I 1.1\n    R F 0.1\n***\n"
                 "    A F 0.1\n    = Q 2.0\n***\n    A I 1.2\n    = F 3.0\n")


def _program(text: str) -> Program:
    built = build(from_string("p.asi", text))
    assert not built.has_errors and built.program is not None, built.render()
    return built.program


def _cells(program: Program) -> list[Key]:
    cycle = build_cycle(program, slaves=(1, 2), cycle_us=10_000, watch=[("Q", 1)])
    return sorted(cycle.post, key=str)


def _run(first: str, second: str, compared: list[Key] | None = None):
    a, b = _program(first), _program(second)
    return corresponding(a, b, (_cells(a), _cells(b)),
                         compared=[(c, c) for c in compared or []], slaves=(1, 2),
                         cycle_us=10_000, host_masks={})


def test_a_renamed_flag_is_paired_with_its_new_name_and_not_with_another():
    run = _run(LATCH, LATCH.replace("F 0.1", "F 7.3"))
    assert Pair((("F", 0), 1), (("F", 7), 3)) in run.pairs
    # F 3.0 follows I 1.2, the latch follows I 1.0 and I 1.1: the run tells them apart
    assert Pair((("F", 3), 0), (("F", 7), 3)) not in run.pairs
    assert Pair((("F", 3), -1), (("F", 3), -1)) in run.pairs
    assert not run.differences


def test_a_flag_that_keeps_an_input_is_paired_with_the_input():
    """An edge's memory (the input as it was) pairs with the input image, which proves
    a network moved into the branch that runs on the edge (tests/prove/
    test_refactorings_composed.py)."""
    memory = LATCH + "***\n    A I 1.3\n    = F 4.2\n"
    run = _run(memory, memory.replace("F 4.2", "F 5.6"))
    assert Pair((("F", 4), 2), (("I", 0), 7)) in run.pairs
    assert Pair((("I", 0), 7), (("F", 5), 6)) in run.pairs
    assert Pair((("F", 4), 2), (("I", 0), 6)) not in run.pairs  # I 1.2: another input


def test_a_complement_is_paired_as_one():
    inverted = LATCH.replace("    A I 1.2\n    = F 3.0\n", "    AN I 1.2\n    = F 3.0\n")
    run = _run(LATCH, inverted)
    assert Pair((("F", 3), 0), (("F", 3), 0), inverted=True) in run.pairs


def test_a_difference_of_the_compared_cells_ends_the_run_with_its_inputs():
    changed = LATCH.replace("    A F 0.1\n    = Q 2.0", "    AN F 0.1\n    = Q 2.0")
    run = _run(LATCH, changed, compared=[("Q", 1)])
    assert run.steps and run.differences
    ((first, second), (x, y)), = run.differences.items()
    assert first == second == ("Q", 1) and x != y
    assert all(set(inputs) == {1, 2} for inputs, _ in run.steps)


def test_a_program_asking_the_firmware_is_never_called_different_by_the_run():
    """The run gives no firmware answers: what it sees of such a program is not what the
    master does, so it proposes pairs but tells no difference."""
    asking = SETUP + "    JU FB GetLAS\n    L PSeg 1\n    T QB 2\n"
    other = SETUP + "    JU FB GetLAS\n    L KB 5\n    T QB 2\n"
    run = _run(asking, other, compared=[("Q", 1)])
    # the run saw QB 2 at 0 (no answer) and 5: not paired, and still no difference told
    assert Pair((("Q", 1), -1), (("Q", 1), -1)) not in run.pairs
    assert run.pairs and not run.differences
