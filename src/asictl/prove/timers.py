"""Candidate facts about timers, drawn from the program, for k-induction to assume once
they are proved.

A timer counts down for thousands of cycles, and plain k-induction looks back only k
cycles: from a state no run reaches (a timer running though nothing started it, a
response waiting longer than its timer can run) the step finds a bad successor, and
k has to grow to the timer's length before the proof goes through. These candidates
rule such states out. None is assumed as it stands: the engine keeps only those
Houdini's algorithm proves inductive (``Machine.houdini``), so a wrong guess costs
time, never a wrong verdict.

- **Started**: while timer n runs, a bit the networks that set or reset it read or
  write has one value (the input that started an on-delay is still on, the flag that
  remembers the start is set).
- **Waiting**: while a response's trigger waits for its answer, a timer runs, and the
  time it still has to run plus the time the trigger has waited is at most its preset
  (and one tick of the clock's phase): the trigger and the timer move together.

The bound on what each timer holds (at most a preset the program loads) is among the
engine's own candidates (``Machine.candidates``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import z3

from asictl.il import ast
from asictl.il.loader import Program
from asictl.platform.master import TICK_US
from asictl.prove.symbolic import TICK, Key, operand_cells, operand_value

K = ast.OperandKind
#: The bit operands a timer's networks name (their words are not facts of this kind).
_BITS = (K.I, K.I2, K.Q, K.F, K.VAR)


class States(Protocol):
    """The states (and response monitors) after consecutive cycles (``engine._Path``)."""

    states: list[dict[Key, z3.BitVecRef]]
    monitors: list[dict[str, z3.ExprRef]]


Fact = Callable[[States, int], z3.BoolRef]
#: A fact's name (for reports), the fact, and the cells it reads.
Candidate = tuple[str, Fact, frozenset[Key]]


def networks(program: Program) -> list[list[ast.Statement]]:
    """The statements of every network (between two ``***``) of every module."""
    found: list[list[ast.Statement]] = []
    for module in program.modules():
        for section in module.sections:
            if not isinstance(section, ast.ProgramSection):
                continue
            current: list[ast.Statement] = []
            for statement in section.statements:
                if isinstance(statement, ast.SegmentEnd):
                    found.append(current)
                    current = []
                else:
                    current.append(statement)
            found.append(current)
    return [network for network in found if network]


def _timer_bits(program: Program) -> dict[int, list[ast.Operand]]:
    """Timer -> the bit operands of the networks that set or reset it, in order."""
    bits: dict[int, list[ast.Operand]] = {}
    for network in networks(program):
        timers = {s.operand.address for s in network
                  if isinstance(s, ast.Store) and s.operand.kind is K.T}
        operands = [s.operand for s in network
                    if isinstance(s, ast.Logic | ast.Store) and s.operand.kind in _BITS
                    and s.operand.width is ast.Width.BIT]
        for n in timers:
            known = bits.setdefault(n, [])
            known.extend(o for o in operands if o not in known)
    return bits


def started(program: Program, cells: frozenset[Key], map_counters: bool) -> list[Candidate]:
    """While timer n runs, each bit its networks name is on (or off)."""
    found: list[Candidate] = []
    for n, operands in sorted(_timer_bits(program).items()):
        timer: Key = ("T", n)
        if timer not in cells:
            continue
        for operand in operands:
            reads = frozenset(operand_cells(operand, map_counters))
            if not reads or not reads <= cells:
                continue
            for value in (1, 0):
                found.append((f"while timer {n} runs, {operand} is {value}",
                              _while_running(timer, operand, value, map_counters),
                              reads | {timer}))
    return found


def _while_running(timer: Key, operand: ast.Operand, value: int,
                   map_counters: bool) -> Fact:
    def fact(path: States, index: int) -> z3.BoolRef:
        state = path.states[index]
        bit = operand_value(operand, state.__getitem__, map_counters)
        result: z3.BoolRef = z3.Implies(state[timer] != 0, bit == value)
        return result

    return fact


def waiting(timers: list[int], presets: list[int], cycle_us: int,
            cells: frozenset[Key]) -> list[Candidate]:
    """While the current response's trigger waits, timer n runs, and its time left
    (the ticks it holds, the next one ``TICK`` away) plus the cycles waited is at most
    a preset (in ticks of 10 ms) and one tick: the timer started with the trigger."""
    found: list[Candidate] = []
    if TICK not in cells:
        return found
    for n in timers:
        timer: Key = ("T", n)
        if timer not in cells:
            continue
        found.append((f"while a trigger waits, timer {n} runs", _running_while_waiting(timer),
                      frozenset({timer})))
        for preset in presets:
            if preset:
                found.append((f"while a trigger waits, timer {n}'s time left and the wait "
                              f"are at most {preset * 10} ms",
                              _left_and_waited(timer, preset, cycle_us),
                              frozenset({timer, TICK})))
    return found


def _running_while_waiting(timer: Key) -> Fact:
    def fact(path: States, index: int) -> z3.BoolRef:
        monitor = path.monitors[index]
        result: z3.BoolRef = z3.Implies(monitor["active"], path.states[index][timer] != 0)
        return result

    return fact


#: Bits wide enough for ticks times 10,000 us plus cycles times the cycle time in us.
WIDE = 64


def wide(term: z3.ExprRef) -> z3.BitVecRef:
    """A bit-vector zero-extended to ``WIDE`` bits."""
    assert isinstance(term, z3.BitVecRef)
    result: z3.BitVecRef = z3.ZeroExt(WIDE - term.size(), term)
    return result


def _left_and_waited(timer: Key, preset: int, cycle_us: int) -> Fact:
    def fact(path: States, index: int) -> z3.BoolRef:
        state, monitor = path.states[index], path.monitors[index]
        spent = (wide(state[TICK]) + wide(state[timer]) * TICK_US
                 + wide(monitor["age"]) * cycle_us)
        result: z3.BoolRef = z3.Implies(monitor["active"],
                                        z3.ULE(spent, (preset + 1) * TICK_US))
        return result

    return fact
