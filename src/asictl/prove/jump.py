"""Idle cycles in one step: a counterexample behind a long timer without unrolling it.

Behind a 20 s timer at 10 ms cycles lie 2,000 cycles in which nothing but the timer
changes; bounded model checking that unrolls them one by one takes minutes. A step of
the search may instead stand for N cycles with the inputs held, when those cycles are
*idle*: the first of them leaves every cell but the timers and the clock's phase as it
found it, and the program sees the same thing in every one of them, so each does the
same. What a cycle sees of a timer is whether it runs (the program never loads a
timer's word: ``jumps_possible``), so the cycles see the same thing when

- a timer the cycle does not store into is stopped, or still runs after the N cycles'
  ticks (it only counts down);
- a timer the cycle stores into already holds what it stores (the same value every
  cycle, as the cells it is stored from do not change), and that value is 0 or more than
  the ticks of one cycle (so it runs in every cycle).

After the N cycles the cells are as after the first, the timers that count down hold
fewer ticks by the ticks of N cycles, and the clock's phase has moved on by N cycle
times. A step of N = 1 is an ordinary cycle, so the steps searched cover every run the
plain search covers and more; a step of N > 1 is a real run of N cycles, and the
counterexample repeats the step's inputs N times (``engine._Path.cycles``), so
``asictl sim`` replays it cycle by cycle. Two programs compared side by side
(``symbolic.product``) are idle when both are: the timers are those of both.

A property is judged after each step: during an idle stretch no operand it may read (no
timer's word) changes, and a response's wait only grows, so a bad state within the
stretch is bad at its end too.
"""

from __future__ import annotations

import z3

from asictl.platform.master import TICK_US
from asictl.prove.symbolic import TICK, Key
from asictl.prove.timers import WIDE, wide

#: The most cycles one step stands for: 2**24 cycles, 46 hours at 10 ms.
MOST = 1 << 24

def ticks_in_a_cycle(cycle_us: int) -> int:
    """The most 10 ms ticks one cycle of ``cycle_us`` sees: a timer that holds more runs
    in every cycle of an idle stretch."""
    return -(-cycle_us // TICK_US)


def idle(cycles: z3.BitVecRef, before: dict[Key, z3.BitVecRef], after: dict[Key, z3.ExprRef],
         stored: dict[Key, z3.BoolRef], cycle_us: int, tag: str) -> tuple[
             dict[Key, z3.ExprRef], list[z3.BoolRef]]:
    """The state after a step of ``cycles`` cycles (32 bits, at least 1) with the inputs
    held, from ``before``, where ``after`` is the state after one cycle and ``stored``
    says, for each timer's cell followed, whether that cycle stores into it (terms over
    ``before`` and the inputs); and the constraints that make a step of more than one
    cycle idle."""
    jump = z3.UGT(cycles, 1)
    rules: list[z3.BoolRef] = [z3.UGE(cycles, 1), z3.ULE(cycles, MOST)]
    ticks = z3.BitVec(f"{tag}ticks", WIDE)
    result = dict(after)
    for cell, term in after.items():
        if cell not in stored and cell != TICK:
            rules.append(z3.Implies(jump, term == before[cell]))
    if TICK in before:
        phase = wide(before[TICK])
        spent = wide(cycles) * cycle_us
        # the ticks in the N cycle times after the phase: the first at ``phase``
        rules.append(z3.If(z3.UGT(phase, spent), ticks == 0, z3.And(
            z3.UGE(ticks, 1), z3.ULE(phase + (ticks - 1) * TICK_US, spent),
            z3.ULT(spent, phase + ticks * TICK_US))))
        moved = z3.Extract(15, 0, phase + ticks * TICK_US - spent)
        result[TICK] = z3.If(jump, moved, after[TICK])
    else:  # no clock followed, so no timer either: nothing to jump over
        rules.append(z3.Not(jump))
    most = ticks_in_a_cycle(cycle_us)
    for cell, term in after.items():
        if cell not in stored:
            continue
        held = before[cell]
        store = stored[cell]
        rules.append(z3.Implies(jump, z3.If(
            store, z3.And(term == held, z3.Or(held == 0, z3.UGT(held, most))),
            z3.Or(held == 0, z3.UGT(wide(held), ticks)))))
        counted = z3.If(held == 0, held, held - z3.Extract(15, 0, ticks))
        result[cell] = z3.If(jump, z3.If(store, term, counted), term)
    return result, rules
