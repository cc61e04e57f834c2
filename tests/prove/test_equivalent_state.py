"""Mutation testing's ``equivalent`` means equivalent for everything a scenario can
expect or a host can read: a mutant that changes only a flag, a timer or a counter the
outputs never show is no equivalent mutant (a scenario expecting that flag kills it)."""

from __future__ import annotations

import pytest

from asictl.build import Build, build
from asictl.prove.diff import equivalent, readable
from asictl.quality.mutate import prove_equivalent
from asictl.source import from_string

pytest.importorskip("z3")

SETUP = "[SETUP]\n1: iiii, 0\n3: oooo, 0\n[PROGRAM]\n"


def _program(logic: str, flag: str, count: str) -> str:
    """Q 3.1 from I 1.0 (``logic`` its first operation), F 10.0 and the count of C 2."""
    return (SETUP + f"    {logic} I 1.0\n    = Q 3.1\n***\n    A {flag}\n    = F 10.0\n***\n"
            f"    A {count}\n    CU C 2\n")


ORIGINAL = _program("A", "I 1.1", "I 1.1")
#: the flag the outputs never show is written with the other input
FLAG = _program("A", "I 1.0", "I 1.1")
#: the counter counts the other input
COUNTER = _program("A", "I 1.1", "I 1.0")
#: O at the start of a chain is A: the same program for every observer
SAME = _program("O", "I 1.1", "I 1.1")


def _build(text: str) -> Build:
    built = build(from_string("p.asi", text))
    assert not built.has_errors, built.render()
    return built


@pytest.mark.parametrize(("text", "differs"), [(FLAG, "FY 10"), (COUNTER, "CV 2")])
def test_a_change_the_outputs_never_show_is_no_equivalent_mutant(text: str, differs: str):
    original, mutant = _build(ORIGINAL), _build(text)
    assert original.program is not None and mutant.program is not None
    # on the outputs alone the two are the same: what mutate used to ask
    assert equivalent(original, mutant, timeout_s=300.0).verdict == "equivalent"
    observe = readable(original.program, mutant.program)
    answer = equivalent(original, mutant, timeout_s=300.0, observe=observe)
    assert answer.verdict == "different"
    assert differs in answer.differences
    verdict = prove_equivalent(original, mutant, prove_s=300.0)
    assert verdict is None or verdict[0] != "equivalent"


def test_a_mutant_the_same_for_every_observer_stays_equivalent():
    verdict = prove_equivalent(_build(ORIGINAL), _build(SAME), prove_s=300.0)
    assert verdict == ("equivalent", "proved equivalent (outputs, flags, timers and counters)")
