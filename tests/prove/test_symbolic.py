"""The symbolic cycle against the simulator's program runner and the reference interpreter.

Hypothesis writes valid programs (every instruction kind, labels and forward jumps, user
function blocks, timers, counters, byte and word operations, variables, gating lines,
map_counters) and runs of cycles with random inputs, host writes to the flags and 10 ms
ticks between them. The symbolic cycle, evaluated on the concrete values, must agree
with the compiled 8051 code (what ``asictl sim`` runs) and with the interpreter on every
output, flag, timer, counter, variable, PSeg byte and register after every cycle. The
default run takes 20 programs of 150 to 180 cycles each (some 3,000 cycles); ``-m slow``
takes 100, more than 15,000 cycles (``ASICTL_PROVE_EXAMPLES`` changes the number of
programs of the default run, and five times it of the long one).

Firmware blocks and PARAM are left out of the generated programs: the prover lets their
answers be anything (docs/prove.md), so there is no single answer to compare.
"""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from il_strategies import checked_programs
from z3_eval import Concrete, compile_terms

from asictl.codegen8051.compiler import compile_program
from asictl.il import ast
from asictl.il.language import MAPPED_COUNTERS
from asictl.il.loader import Program
from asictl.il.oracle import Interpreter
from asictl.platform.master import COUNTER_HIGH_FLAGS
from asictl.prove.symbolic import (
    ACCU1,
    ACCU2,
    CONSTANT,
    TICK,
    Key,
    Unmodelled,
    build_cycle,
)
from asictl.runtime.program_map import LoadedProgram, Location, Space
from asictl.runtime.runner import CycleTimeout, ProgramRunner
from asictl.source import from_string

EXAMPLES = int(os.environ.get("ASICTL_PROVE_EXAMPLES", "20"))
#: cycle periods: 0 or 1, 2 or 3, and 60 or 61 ticks of the 10 ms clock between cycles
PERIODS_US = (5_000, 25_000, 605_000)
K = ast.OperandKind
HOST = [ast.Operand.of(K.FY, n) for n in range(128)]
runs = st.lists(
    st.tuples(
        st.binary(min_size=16, max_size=16),
        st.booleans(),  # the 10 ms clock's extra tick in this cycle
        st.none() | st.tuples(st.integers(0, 127), st.integers(0, 255)),
    ),
    min_size=150,
    max_size=180,
)


def _without_firmware(program: Program) -> Program:
    def keep(node: object) -> bool:
        if isinstance(node, ast.Param):
            return False
        return not (isinstance(node, ast.CallFB) and node.name.casefold() not in program.blocks)

    def module(m: ast.Module) -> ast.Module:
        sections = tuple(
            ast.ProgramSection(tuple(s for s in section.statements if keep(s)))
            if isinstance(section, ast.ProgramSection) else section
            for section in m.sections
        )
        return ast.Module(m.file, sections)

    return Program(main=module(program.main),
                   blocks={n: module(b) for n, b in program.blocks.items()},
                   sources=program.sources, fb_decls=program.fb_decls)


def _ticks_before(period_us: int, extra: bool) -> tuple[int, int]:
    """The time to the next tick at a cycle's start that gives the previous cycle its
    extra tick (or not), and the number of ticks."""
    whole, rest = divmod(period_us, 10_000)
    return (1, whole + 1) if extra else (rest + 1, whole)


def _word(runner: ProgramRunner, address: int) -> int:
    xdata = runner.cpu.xdata
    return xdata.read(address) | xdata.read(address + 1) << 8


def _expected(interp: Interpreter, runner: ProgramRunner, compiled) -> dict[Key, int]:
    """Every cell of the symbolic cycle, as the runner holds it (checked against the
    interpreter on the way)."""
    state, pmap, cpu = interp.state, compiled.pmap, runner.cpu
    cells: dict[Key, int] = {}
    for n in range(16):
        cells[("I", n)] = state.inputs[n]
        cells[("I2", n)] = state.old_inputs[n]
        cells[("Q", n)] = runner.outputs[n]
        cells[("P", n)] = cpu.xdata.read(pmap.pseg + n)
    assert bytes(runner.outputs) == bytes(state.outputs)
    for n in range(128):
        cells[("F", n)] = runner.flag(n)
    for n, address in pmap.timers.items():
        cells[("T", n)] = _word(runner, address)
    for n, address in pmap.counters.items():
        if not (interp.map_counters and n < MAPPED_COUNTERS):  # else in the flags
            cells[("C", n)] = _word(runner, address) & 0x0FFF
    for name, variable in pmap.variables.items():
        for i in range(variable.size):
            cells[("V", name, i)] = cpu.xdata.read(variable.address + i)
    cells[ACCU1] = cpu.iram[6] << 8 | cpu.iram[7]
    cells[ACCU2] = cpu.iram[4] << 8 | cpu.iram[5]
    cells[CONSTANT] = cpu.iram[3] << 8 | cpu.iram[2]
    assert (cells[ACCU1], cells[ACCU2], cells[CONSTANT]) == (
        state.accu1, state.accu2, state.constant)
    return cells


CYCLES = [0]


@settings(max_examples=EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(checked_programs(asm=False, options=True), runs, st.sampled_from(PERIODS_US))
def test_the_symbolic_cycle_agrees_with_the_simulator(program: Program, run,
                                                      period_us: int) -> None:
    symbolic_cycle_agrees(program, run, period_us)


@pytest.mark.slow
@settings(max_examples=5 * EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(checked_programs(asm=False, options=True), runs, st.sampled_from(PERIODS_US))
def test_the_symbolic_cycle_agrees_with_the_simulator_long(program: Program, run,
                                                           period_us: int) -> None:
    symbolic_cycle_agrees(program, run, period_us)


def symbolic_cycle_agrees(program: Program, run: list, period_us: int) -> None:
    program = _without_firmware(program)
    compiled = compile_program(program)
    interp = Interpreter(program)
    runner = ProgramRunner(LoadedProgram(compiled.code, compiled.pmap, compiled.entry_points))
    cycle = build_cycle(program, slaves=range(32), cycle_us=period_us, host_flags=HOST)
    concrete = Concrete(cycle)
    for number, (inputs, extra, host_write) in enumerate(run):
        until, ticks = _ticks_before(period_us, extra)
        if number and ticks:
            interp.tick(ticks)
            runner.tick(ticks)
        given_inputs = {f"in.{a}": inputs[a >> 1] >> (a & 1) * 4 & 0xF for a in range(32)}
        flags = {f"host.{n}": concrete.state.get(("F", n), 0) for n in range(128)}
        if host_write is not None:
            n, value = host_write
            if interp.map_counters and n in COUNTER_HIGH_FLAGS:
                value &= 0x0F  # the board keeps a mapped counter's high byte in 0..15
            interp.state.flags[n] = value
            runner.write(Location(Space.XDATA, 0x200 + n), value)
            flags[f"host.{n}"] = value
        if number:  # the first cycle has no cycle before it
            concrete.state[TICK] = until
        try:
            interp.cycle(inputs)
        except CycleTimeout:
            return
        runner.cycle(inputs)
        if interp.map_counters:  # and so it does after every cycle (board/board.py)
            for n in COUNTER_HIGH_FLAGS:
                interp.state.flags[n] &= 0x0F
                runner.write(Location(Space.XDATA, 0x200 + n), runner.flag(n) & 0x0F)
        after = concrete.step({**given_inputs, **flags})
        assert 1 <= concrete.state.get(TICK, 1) <= 10_000
        expected = _expected(interp, runner, compiled)
        diverging = {cell: (after.get(cell, 0), value) for cell, value in expected.items()
                     if after.get(cell, 0) != value}
        assert not diverging, f"after cycle {number}: cell: (symbolic, simulator) {diverging}"
        CYCLES[0] += 1


def _cycle_of(text: str) -> tuple[Program, Concrete]:
    from asictl.build import check

    built = check(from_string("p.asi", text))
    assert not built.has_errors, built.render()
    assert built.program is not None
    return built.program, Concrete(build_cycle(built.program, slaves=[1, 2],
                                               cycle_us=5_000))


def test_a_loop_is_unrolled_and_agrees_with_the_interpreter():
    program, concrete = _cycle_of(
        "[SETUP]\n1: iiii, 0\n2: oooo, 0\n[PROGRAM]\n    L KB 0\n    T FY 10\n"
        "loop: L FY 10\n    L KB 16\n    + F\n    T FY 10\n    L FY 10\n    L IB 0\n"
        "    >< F\n    JC loop\n    A F 10.5\n    = Q 2.0\n")
    interp = Interpreter(program)
    overrun = compile_terms([concrete.cycle.overrun])
    for value in (1, 3, 5, 8, 2):  # I 1 = value: the loop runs value times
        inputs = bytes([value << 4]) + bytes(15)
        interp.cycle(inputs)
        before = {str(var): concrete.state.get(cell, 0) for cell, var in concrete.cycle.pre.items()}
        assert overrun({**before, "in.1": value}) == [0]
        after = concrete.step({"in.1": value})
        assert after[("F", 10)] == interp.state.flags[10] == value * 16
        assert after[("Q", 1)] == interp.state.outputs[1]
    for value in (0, 10, 15):  # 16, 10 and 15 runs: the jump taken more than 8 times
        assert overrun({"in.1": value}) == [1]
    assert [loop.bound for loop in concrete.cycle.loops] == [8]


def test_asm_is_refused_naming_its_line():
    from asictl.build import check

    built = check(from_string("p.asi", "[PROGRAM]\n    A I 1.0\n    ASM nop\n"))
    assert built.program is not None
    with pytest.raises(Unmodelled) as refused:
        build_cycle(built.program, slaves=[1], cycle_us=5_000)
    assert "nop" in str(refused.value)
    assert refused.value.span is not None and refused.value.span.line == 3
