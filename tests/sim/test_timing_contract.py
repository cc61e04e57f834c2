"""The simulation timing contract (docs/simulation.md) against an independent simulator.

The contract: time 0 is the first program cycle; a ``set`` at T takes effect for every
cycle that starts at or after T; an ``expect`` at T sees the state the cycles that
started before T left. With ``cycle_ms = P`` the cycles start at 0, P, 2P, ...

The independent simulator is the reference interpreter (``il.reference``, which shares
no code with the compiler, the board or the engine) driven by this contract alone: its
cycle k runs at k*P with the inputs and flags of every step at or before k*P, and an
expectation at T is read after the cycles before T. Generated programs count cycles
(flag bytes incremented every cycle, counters counted up on inputs), so a cycle too
many or too few, or an input seen one cycle late, changes what is expected.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from il_strategies import Scope, programs

from asictl.build import build
from asictl.il import ast
from asictl.il.checks import check_program
from asictl.il.loader import Program
from asictl.il.oracle import Interpreter
from asictl.runtime.runner import CycleTimeout
from asictl.sim.engine import Simulation, variables_of
from asictl.sim.scenario import read_scenario
from asictl.source import from_string

EXAMPLES = int(os.environ.get("ASICTL_TIMING_EXAMPLES", "40"))
SLAVES = "[SETUP]\n1: iiii, 0\n2: iiii, 0\n3: oooo, 0\n"


def simulate(program_text: str, scenario_text: str) -> list[tuple]:
    """asictl's answers: (line, operand, expected, got) of every failed expectation."""
    built = build(from_string("prog.asi", program_text))
    assert not built.has_errors, built.render()
    assert built.image is not None
    scenario = read_scenario(from_string("s.toml", scenario_text),
                             variables_of(built.image.pmap))
    result = Simulation(built, scenario).run()
    assert not result.stops, result.stops
    return [(f.line, str(f.operand), f.expected, f.got) for f in result.failures]


# ------------------------------------------------------------------ the two reported cases


def test_an_input_set_at_time_0_is_seen_by_the_first_cycle():
    program = SLAVES + "[PROGRAM]\n    AN I 1.0\n    S F 10.0\n"
    scenario = ('[master]\ncycle_ms = 5\n[[step]]\nat_ms = 0\nset = { "I 1.0" = 1 }\n'
                '[[step]]\nat_ms = 50\nexpect = { "F 10.0" = 0 }\n')
    assert simulate(program, scenario) == []


def test_no_cycle_runs_before_time_0_and_an_expect_sees_the_cycles_before_it():
    program = SLAVES + "[PROGRAM]\n    L FY 10\n    L KB 1\n    + F\n    T FY 10\n"
    scenario = (
        '[master]\ncycle_ms = 5\n'
        '[[step]]\nat_ms = 0\nexpect = { "FY 10" = 0 }\n'  # no cycle before 0
        '[[step]]\nat_ms = 0.001\nexpect = { "FY 10" = 1 }\n'  # the cycle at 0
        '[[step]]\nat_ms = 5\nexpect = { "FY 10" = 1 }\n'  # the cycle at 5 not yet
        '[[step]]\nat_ms = 50\nexpect = { "FY 10" = 10 }\n'  # cycles 0, 5, ..., 45
    )
    assert simulate(program, scenario) == []


def test_a_set_at_a_cycle_start_is_seen_by_that_cycle():
    program = SLAVES + "[PROGRAM]\n    A I 1.0\n    CU C 0\n"
    scenario = (
        '[master]\ncycle_ms = 5\n'
        '[[step]]\nat_ms = 10\nset = { "I 1.0" = 1 }\n'  # cycles at 10, 15 count
        '[[step]]\nat_ms = 20\nset = { "I 1.0" = 0 }\nexpect = { "CV 0" = 2 }\n'
        '[[step]]\nat_ms = 100\nexpect = { "CV 0" = 2, "C 0" = 1 }\n'
    )
    assert simulate(program, scenario) == []


# ------------------------------------------------------------------ generated programs


def _clean(section: ast.ProgramSection) -> ast.ProgramSection:
    """What the reference interpreter runs exactly as the master does: no ASM, no
    firmware blocks (the master's really act on its bus), no timers (their 10 ms clock
    runs independently of time 0), no backward jumps (endless loops)."""
    seen: set[str] = set()
    kept: list[ast.Statement] = []
    for s in section.statements:
        if isinstance(s, ast.Label):
            seen.add(s.name.casefold())
        if isinstance(s, ast.Asm | ast.CallFB | ast.Param):
            continue
        if isinstance(s, ast.Jump) and s.label.casefold() in seen:
            continue
        if any(o.kind is ast.OperandKind.T for o, _ in ast.operands(s)):
            continue
        kept.append(s)
    return ast.ProgramSection(tuple(kept))


COUNTING = ast.ProgramSection((  # state that depends on the number of cycles
    ast.Load(ast.Operand.of(ast.OperandKind.FY, 10)),
    ast.Load(ast.Operand.of(ast.OperandKind.KB, 1)),
    ast.Arith(ast.ArithOp.ADD),
    ast.Transfer(ast.Operand.of(ast.OperandKind.FY, 10)),
    ast.SegmentEnd(),
    ast.Logic(ast.LogicOp.A, ast.Operand.of(ast.OperandKind.I, 1, 0)),
    ast.Count(ast.CountOp.CU, ast.Operand.of(ast.OperandKind.C, 1, width=ast.Width.WORD)),
    ast.Logic(ast.LogicOp.A, ast.Operand.of(ast.OperandKind.I2, 1, 1)),
    ast.Count(ast.CountOp.CU, ast.Operand.of(ast.OperandKind.C, 2, width=ast.Width.WORD)),
    ast.SegmentEnd(),
))


@st.composite
def counting_programs(draw: st.DrawFn) -> Program:
    setup = ast.SetupSection(tuple(ast.SlaveSetup(a, 0, 0, None) for a in (1, 2)))
    body = [COUNTING, *(_clean(draw(programs(Scope()))) for _ in range(draw(st.integers(0, 2))))]
    main = ast.Module("prog.asi", (setup, *body))
    program = Program(main=main)
    assume(not any(d.is_error for d in check_program(program)))
    return program


#: Slave 2 is read only through I2, never through I: a cycle that changes nothing but the
#: previous-input image still changes the next cycle (the board's cycle skipping once
#: missed that, and I2 never caught up).
PREVIOUS_ONLY = ast.ProgramSection((
    ast.Logic(ast.LogicOp.A, ast.Operand.of(ast.OperandKind.I2, 2, 0)),
    ast.Store(ast.StoreOp.ASSIGN, ast.Operand.of(ast.OperandKind.Q, 30, 0)),
    ast.Logic(ast.LogicOp.O, ast.Operand.of(ast.OperandKind.I2, 2, 3)),
    ast.Count(ast.CountOp.CU, ast.Operand.of(ast.OperandKind.C, 3, width=ast.Width.WORD)),
    ast.SegmentEnd(),
))


def _previous_only(section: ast.ProgramSection) -> ast.ProgramSection:
    """The section without any reading of slave 2's (or 3's) current inputs."""
    def current(o: ast.Operand) -> bool:
        return (o.kind is ast.OperandKind.I and o.address in (2, 3)) or (
            o.kind is ast.OperandKind.IB and o.address == 2)

    return ast.ProgramSection(tuple(
        s for s in section.statements if not any(current(o) for o, _ in ast.operands(s))
    ))


@st.composite
def previous_input_programs(draw: st.DrawFn) -> Program:
    setup = ast.SetupSection(tuple(ast.SlaveSetup(a, 0, 0, None) for a in (1, 2)))
    body = [PREVIOUS_ONLY, *(_previous_only(_clean(draw(programs(Scope()))))
                             for _ in range(draw(st.integers(0, 2))))]
    main = ast.Module("prog.asi", (setup, *body))
    program = Program(main=main)
    assume(not any(d.is_error for d in check_program(program)))
    return program


@dataclass(frozen=True)
class StepSpec:
    at_ms: float
    inputs: tuple[tuple[int, int], ...]  # (slave, nibble)
    flags: tuple[tuple[int, int], ...]  # (flag byte, value)
    expect: bool


cycle_periods = st.sampled_from([1.0, 2.5, 5.0, 10.0])


@st.composite
def step_lists(draw: st.DrawFn, period: float) -> list[StepSpec]:
    # times on cycle starts, just after, just before, or anywhere: the boundaries matter
    times = st.one_of(
        st.integers(0, 30).map(lambda k: k * period),
        st.integers(0, 30).map(lambda k: round(k * period + 0.001, 3)),
        st.integers(1, 30).map(lambda k: round(k * period - 0.001, 3)),
        st.integers(0, 30_000).map(lambda us: us / 1000),
    )
    steps = []
    for _ in range(draw(st.integers(1, 8))):
        steps.append(StepSpec(
            draw(times),
            tuple(draw(st.lists(st.tuples(st.sampled_from([1, 2]), st.integers(0, 15)),
                                max_size=2, unique_by=lambda x: x[0]))),
            tuple(draw(st.lists(st.tuples(st.integers(0, 127).filter(lambda n: n != 10),
                                          st.integers(0, 255)),
                                max_size=2, unique_by=lambda x: x[0]))),
            draw(st.booleans()),
        ))
    steps.append(StepSpec(draw(times), (), (), True))
    return steps


#: (an output of a slave never on the bus is no expectation: a scenario refuses it, E402)
WATCHED = ("FY 10", "CV 1", "CV 2", "CV 3", "QB 0", "QB 2")


def reference_values(program: Program, period: float, steps: list[StepSpec],
                     watched: tuple[str, ...]) -> list[dict[str, int]]:
    """What the contract makes each watched operand at each step (None: no expect)."""
    interp = Interpreter(program)
    slaves = {1: 0, 2: 0}
    values: list[dict[str, int]] = [{} for _ in steps]
    cycle = 0
    for at in sorted({s.at_ms for s in steps}):
        while cycle * period < at:  # the cycles that start before `at` see what came before
            image = bytearray(16)
            for address, nibble in slaves.items():
                image[address >> 1] |= nibble << (address & 1) * 4
            interp.cycle(bytes(image))
            cycle += 1
        group = [i for i, s in enumerate(steps) if s.at_ms == at]
        for i in group:  # sets before checks at equal times
            for address, nibble in steps[i].inputs:
                slaves[address] = nibble
            for flag, value in steps[i].flags:
                interp.state.flags[flag] = value
        for i in group:
            if steps[i].expect:
                values[i] = {name: read(interp, name) for name in watched}
    return values


def read(interp: Interpreter, name: str) -> int:
    state = interp.state
    kind, number = name.split()
    n = int(number)
    if kind == "FY":
        return state.flags[n]
    if kind == "QB":
        return state.outputs[n >> 1]
    if interp.map_counters and n < 15:  # counters 0..14 are flag bytes 96+2n, 97+2n
        return (state.flags[97 + 2 * n] & 0x0F) << 8 | state.flags[96 + 2 * n]
    return state.counters.get(n, 0)


def scenario_text(period: float, steps: list[StepSpec], values: list[dict[str, int]]) -> str:
    out = [f"[master]\ncycle_ms = {period}\n"]
    for step, expected in zip(steps, values, strict=True):
        out.append(f"[[step]]\nat_ms = {step.at_ms}\n")
        sets = [f'"I {a}.{b}" = {n >> b & 1}' for a, n in step.inputs for b in range(4)]
        sets += [f'"FY {f}" = {v}' for f, v in step.flags]
        if sets:
            out.append("set = { " + ", ".join(sets) + " }\n")
        if expected:
            out.append("expect = { " + ", ".join(f'"{k}" = {v}' for k, v in expected.items())
                       + " }\n")
    return "".join(out)


@settings(max_examples=EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(counting_programs(), cycle_periods.flatmap(lambda p: st.tuples(st.just(p),
                                                                        step_lists(p))))
def test_generated_programs_agree_with_the_reference_interpreter(program: Program, timing):
    assert_agrees(program, *timing)


def assert_agrees(program: Program, period: float, steps: list[StepSpec]) -> None:
    """The simulated master gives every watched operand, at every step, the value the
    reference interpreter gives it under the timing contract."""
    watched = (*WATCHED, *sorted({f"FY {f}" for s in steps for f, _ in s.flags}))
    try:
        values = reference_values(program, period, steps, watched)
    except CycleTimeout:
        assume(False)
    assert simulate(program.main.to_source(), scenario_text(period, steps, values)) == []


@settings(max_examples=EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(previous_input_programs(), cycle_periods.flatmap(lambda p: st.tuples(st.just(p),
                                                                             step_lists(p))))
def test_programs_that_read_only_previous_inputs_agree_with_the_reference_interpreter(
    program: Program, timing
):
    assert_agrees(program, *timing)
