"""The prover's verdicts against exhaustive simulation: a soundness campaign.

Hypothesis writes small programs (bit logic, set and reset, flags remembered from one
cycle to the next, a timer) and properties over them (never, always, reachable, and
responses within a few cycles). Each verdict is checked by an oracle that shares no
code with the prover: the reference interpreter (``il/oracle.py``) run from the reset
over **every** input sequence up to a depth (breadth first over the distinct states the
sequences reach, with the 10 ms tick between the cycles), and the simulator that runs
the compiled 8051 code (``asictl sim``):

- ``proved`` and ``unreachable``: no input sequence up to the depth breaks (reaches) it;
- ``refuted`` and ``reached``: the shortest sequence that breaks (reaches) it has as many
  cycles as the prover's, and its scenario replayed by the simulator fails at its last
  step (a witness passes);
- ``holds up to N cycles``: none breaks it within N cycles.

The programs run with 4, 10 or 25 ms cycles, so none, one, two or three ticks of the
10 ms clock fall between two cycles, as its phase has it: the interpreter runs every
input sequence on five phases (and on the one a counterexample names), a proof must
hold on all of them, a counterexample be the shortest on its own and no longer than any
other's. The default run takes ``ASICTL_SOUNDNESS_EXAMPLES``
programs (8) to a depth of 5 cycles, a few seconds; ``-m slow`` takes 25 times as many
to a depth of 7.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from replay import assert_replays

from asictl.build import build_file
from asictl.il import ast
from asictl.il.loader import Program
from asictl.il.oracle import Interpreter, PlcState
from asictl.observe.condition import Expr, holds
from asictl.observe.operands import Operand
from asictl.prove.engine import Verdict
from asictl.prove.props import Kind, Property
from asictl.prove.session import prove as prove_file

pytest.importorskip("z3")

EXAMPLES = int(os.environ.get("ASICTL_SOUNDNESS_EXAMPLES", "8"))
K = ast.OperandKind
INPUTS = ["I 1.0", "I 1.1", "I 1.2"]
OUTPUTS = ["Q 2.0", "Q 2.1", "Q 2.2", "Q 2.3"]
FLAGS = ["F 0.0", "F 0.1", "F 0.2"]
READ = INPUTS + OUTPUTS + FLAGS + ["T 1", "I2 1.0"]
WRITTEN = OUTPUTS + FLAGS
OBSERVED = INPUTS + OUTPUTS + FLAGS + ["T 1"]
#: 10 ms: one tick between two cycles, whatever the clock's phase; 4 ms: none or one;
#: 25 ms: two or three
CYCLES_MS = (10, 4, 25)
#: phases of the clock (time 0 to the first tick, in us) every verdict is checked on
PHASES_US = (1, 2_500, 5_000, 7_500, 10_000)


@st.composite
def networks(draw: st.DrawFn) -> str:
    """One network: a chain of bit checks and a store, or a timer start."""
    terms = draw(st.lists(st.sampled_from(READ), min_size=1, max_size=3))
    ops = [draw(st.sampled_from(["A", "AN"]))] + [
        draw(st.sampled_from(["A", "AN", "O", "ON"])) for _ in terms[1:]]
    lines = [f"        {op:<4}{term}" for op, term in zip(ops, terms, strict=True)]
    if draw(st.integers(0, 4)) == 0:
        ticks = draw(st.sampled_from([10, 20, 30]))
        lines = [f"        L   KT {ticks}", *lines,
                 f"        {draw(st.sampled_from(['S', 'R']))}   T 1"]
    else:
        store = draw(st.sampled_from(["=", "S", "R"]))
        lines.append(f"        {store:<4}{draw(st.sampled_from(WRITTEN))}")
    return "\n".join(lines) + "\n***\n"


#: every program starts T 1 from I 1.0 (so that a property may name it), then 1 to 4
#: networks
programs = st.tuples(st.sampled_from([10, 20, 30]), st.lists(networks(), min_size=1,
                                                            max_size=4)).map(
    lambda parts: ("[SETUP]\n1: iiii, 0\n2: oooo, 0\n\n[PROGRAM]\n"
                   f"        L   KT {parts[0]}\n        A   I 1.0\n        S   T 1\n***\n"
                   + "".join(parts[1])))


@st.composite
def conditions(draw: st.DrawFn) -> str:
    literals = [("not " if draw(st.booleans()) else "") + draw(st.sampled_from(OBSERVED))
                for _ in range(draw(st.integers(1, 3)))]
    joined = literals[0]
    for literal in literals[1:]:
        joined += f" {draw(st.sampled_from(['and', 'or']))} {literal}"
    return joined


@st.composite
def properties(draw: st.DrawFn) -> str:
    found = []
    for number in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["never", "always", "reachable", "when"]))
        text = f'[[property]]\nname = "p{number}"\n'
        if kind == "when":
            text += (f'when = "{draw(conditions())}"\nthen = "{draw(conditions())}"\n'
                     f'within = "{draw(st.integers(1, 3))} cycles"\n')
        else:
            text += f'{kind} = "{draw(conditions())}"\n'
        found.append(text)
    return f"[master]\ncycle_ms = {draw(st.sampled_from(CYCLES_MS))}\n" + "".join(found)


def _reader(state: PlcState) -> Callable[[Operand], int]:
    def read(operand: Operand) -> int:
        node = operand.node
        match node.kind:
            case K.I | K.I2 | K.Q:
                image = {K.I: state.inputs, K.I2: state.old_inputs,
                         K.Q: state.outputs}[node.kind]
                return image[node.address >> 1] >> ((node.address & 1) * 4 + node.bit) & 1
            case K.F:
                return state.flags[node.address] >> node.bit & 1
            case K.T:
                return int(state.timers.get(node.address, 0) > 0)
            case _:
                raise AssertionError(f"{operand} is not generated")
    return read


def _key(state: PlcState) -> tuple[object, ...]:
    return (bytes(state.inputs), bytes(state.old_inputs), bytes(state.outputs),
            bytes(state.flags), tuple(sorted(state.timers.items())), state.accu1,
            state.accu2, state.constant)


@dataclass
class _Node:
    state: PlcState
    #: a response's monitor: cycles since its oldest unanswered trigger (None: none)
    pending: int | None = None


def _ticks(cycle_us: int, phase_us: int, cycle: int) -> int:
    """The ticks between the start of cycle ``cycle`` - 1 and its own (counted from 1;
    none before the first), the first at ``phase_us`` and then every 10 ms: a tick at
    a cycle's start comes before it (the timing contract)."""
    if cycle == 1:
        return 0

    def until(t: int) -> int:  # ticks at or before t
        return 0 if t < phase_us else (t - phase_us) // 10_000 + 1

    return until((cycle - 1) * cycle_us) - until((cycle - 2) * cycle_us)


def _first_bad(program: Program, prop: Property, depth: int, cycle_us: int,
               phase_us: int) -> int | None:
    """The fewest cycles after which some input sequence breaks ``prop`` (for
    ``reachable``: reaches it) on the clock's phase ``phase_us``, or None within
    ``depth`` cycles: every input sequence, breadth first over the distinct states (and
    response monitors) they reach."""
    interp = Interpreter(program)
    frontier: dict[tuple[object, ...], _Node] = {("reset",): _Node(interp.state)}
    for cycle in range(1, depth + 1):
        after: dict[tuple[object, ...], _Node] = {}
        ticks = _ticks(cycle_us, phase_us, cycle)
        for node in frontier.values():
            for nibble in range(8):
                interp.state = node.state.copy()
                if ticks:
                    interp.tick(ticks)
                interp.cycle(bytes([nibble << 4]) + bytes(15))
                read = _reader(interp.state)
                pending, bad = _judge(prop, read, node.pending)
                if bad:
                    return cycle
                after.setdefault((*_key(interp.state), pending),
                                 _Node(interp.state, pending))
        frontier = after
    return None


def _judge(prop: Property, read: Callable[[Operand], int],
           pending: int | None) -> tuple[int | None, bool]:
    """The monitor after a cycle, and whether the property is broken (reached) there."""
    def true(expr: Expr) -> bool:
        return holds(expr, read)

    match prop.kind:
        case Kind.NEVER | Kind.REACHABLE:
            return None, true(prop.expr)
        case Kind.ALWAYS:
            return None, not true(prop.expr)
        case Kind.RESPONSE:
            assert prop.then is not None and prop.within_cycles is not None
            if true(prop.then):
                return None, False
            if pending is None:
                pending = 0 if true(prop.expr) else None
            else:
                pending += 1
            return pending, pending is not None and pending >= prop.within_cycles
    raise AssertionError(prop.kind)


def verdicts_agree(program: str, props: str, depth: int) -> None:
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "p.asi").write_text(program)
        (Path(folder) / "p.props.toml").write_text(props)
        report = prove_file(Path(folder) / "p.props.toml", timeout_s=120.0, depth=depth)
        built = build_file(Path(folder) / "p.asi")
        assert built.program is not None
        cycle_us = round(report.cycle_ms * 1000)
        for outcome in report.outcomes:
            prop = outcome.prop
            cycles = outcome.depth + 1
            first = {phase: _first_bad(built.program, prop, depth + 1, cycle_us, phase)
                     for phase in {*PHASES_US, outcome.phase_us or 1}}
            where = f"{program}\n{props}\n{outcome.verdict}: {outcome.note}\n{first}"
            match outcome.verdict:
                case Verdict.PROVED | Verdict.UNREACHABLE:
                    assert set(first.values()) == {None}, where
                case Verdict.REFUTED | Verdict.REACHED:
                    # the shortest on its phase, and none shorter on any other
                    assert first[outcome.phase_us or 1] == cycles, where
                    assert all(n is None or n >= cycles for n in first.values()), where
                    assert_replays(Path(folder) / "p.asi",
                                   report.written[prop.name], outcome.verdict)
                case Verdict.BOUNDED:
                    assert all(n is None or n > cycles for n in first.values()), where
                case Verdict.UNKNOWN:
                    pass
            SEEN[outcome.verdict] = SEEN.get(outcome.verdict, 0) + 1


#: verdicts checked so far, by kind (for a campaign run from a script)
SEEN: dict[Verdict, int] = {}


@settings(max_examples=EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(programs, properties())
def test_verdicts_agree_with_every_input_sequence(program: str, props: str) -> None:
    verdicts_agree(program, props, depth=5)


@pytest.mark.slow
@settings(max_examples=10 * EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(programs, properties())
def test_verdicts_agree_with_every_input_sequence_long(program: str, props: str) -> None:
    verdicts_agree(program, props, depth=7)
