"""The compiled code against the reference interpreter, on generated programs.

Hypothesis writes valid programs (every instruction kind, labels and forward jumps,
user and firmware block calls, timers, counters, byte and word operations, variables,
gating lines, map_counters) and a run of cycles with random inputs, host writes to the
flags and timer ticks in between. The 8051 code on the emulator and the interpreter must
agree on every output, flag, timer, counter, variable, PSeg byte and IL register after
every cycle.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from il_strategies import gatings, programs, scopes

from asictl.codegen8051.compiler import compile_program
from asictl.il import ast
from asictl.il.checks import check_program
from asictl.il.loader import Program
from asictl.il.reference import CycleTimeout as InterpreterTimeout
from asictl.il.reference import Interpreter
from asictl.runtime.program_map import LoadedProgram, Location, Space
from asictl.runtime.runner import CycleTimeout, ProgramRunner

EXAMPLES = int(os.environ.get("ASICTL_DIFF_EXAMPLES", "2000"))


class ModelFirmware:
    """A deterministic stand-in for the master's firmware blocks."""

    def call(self, name: str, pseg: bytearray) -> None:
        h = (sum(pseg[:4]) * 7 + len(name)) & 0xFF
        pseg[0] = 0 if h % 3 else 0x80
        pseg[1] = (pseg[1] ^ h) & 0xFF
        pseg[2] = h


def _runnable(section: ast.ProgramSection) -> ast.ProgramSection:
    """Drop ASM lines (the interpreter has no 8051) and backward jumps (endless loops)."""
    seen: set[str] = set()
    kept = []
    for statement in section.statements:
        if isinstance(statement, ast.Label):
            seen.add(statement.name.casefold())
        if isinstance(statement, ast.Asm):
            continue
        if isinstance(statement, ast.Jump) and statement.label.casefold() in seen:
            continue
        kept.append(statement)
    return ast.ProgramSection(tuple(kept))


@st.composite
def runnable_programs(draw: st.DrawFn) -> Program:
    scope, decl = draw(scopes())
    decl = ast.DeclSection(tuple(d for d in decl.declarations if not isinstance(d, ast.FBDecl)))
    blocks = {}
    names = draw(st.lists(st.sampled_from(["BlkA", "BlkB"]), unique=True, max_size=2))
    for name in names:
        body = [_runnable(draw(programs(scope)))]
        blocks[name.casefold()] = ast.Module(f"{name}.fb", tuple(body))
    sections: list = []
    if draw(st.booleans()):
        sections.append(ast.OptionsSection((ast.Option("map_counters", draw(st.booleans())),)))
    sections.append(ast.DeclSection(
        (*decl.declarations, *(ast.FBDecl(n, f"{n}.fb") for n in names))
    ))
    for _ in range(draw(st.integers(1, 3))):
        if draw(st.integers(0, 3)):
            section = _runnable(draw(programs(scope)))
            statements = list(section.statements)
            for name in names:
                call = ast.CallFB(draw(st.booleans()), name)
                statements.insert(draw(st.integers(1, max(1, len(statements)))), call)
            sections.append(ast.ProgramSection(tuple(statements)))
        else:
            sections.append(draw(gatings(scope)))
    main = ast.Module("main.asi", tuple(sections))
    program = Program(main=main, blocks=blocks)
    for name in names:
        program.fb_decls[name.casefold()] = ast.FBDecl(name, f"{name}.fb")
    assume(not any(d.is_error for d in check_program(program)))
    return program


steps = st.lists(
    st.tuples(
        st.binary(min_size=16, max_size=16),  # inputs of the cycle
        st.sampled_from([0, 0, 1, 2, 5, 60]),  # 10 ms ticks before it
        st.none() | st.tuples(st.integers(0, 127), st.integers(0, 255)),  # a host flag write
    ),
    min_size=1,
    max_size=8,
)


def _word(runner: ProgramRunner, address: int) -> int:
    xdata = runner.cpu.xdata
    return xdata.read(address) | xdata.read(address + 1) << 8


def _assert_same(interp: Interpreter, runner: ProgramRunner, compiled, cycle: int) -> None:
    state, pmap, cpu = interp.state, compiled.pmap, runner.cpu
    where = f"after cycle {cycle}"
    assert bytes(runner.outputs) == bytes(state.outputs), f"outputs {where}"
    assert bytes(runner.flag(n) for n in range(128)) == bytes(state.flags), f"flags {where}"
    for n, address in pmap.timers.items():
        assert _word(runner, address) == state.timers.get(n, 0), f"timer {n} {where}"
    for n, address in pmap.counters.items():
        assert _word(runner, address) & 0x0FFF == interp._counter(n), f"counter {n} {where}"
    for name, variable in pmap.variables.items():
        data = bytes(cpu.xdata.read(variable.address + i) for i in range(variable.size))
        assert data == bytes(state.variables[name]), f"variable {variable.name} {where}"
    pseg = bytes(cpu.xdata.read(pmap.pseg + i) for i in range(16))
    assert pseg == bytes(state.pseg), f"PSeg {where}"
    assert cpu.iram[6] << 8 | cpu.iram[7] == state.accu1, f"ACCU1 {where}"
    assert cpu.iram[4] << 8 | cpu.iram[5] == state.accu2, f"ACCU2 {where}"
    assert cpu.iram[3] << 8 | cpu.iram[2] == state.constant, f"constant register {where}"
    assert bool(cpu.sfr[0xD0] & 0x80) == state.rlo, f"single-bit register {where}"


@settings(
    max_examples=EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
@given(runnable_programs(), steps)
def test_compiled_code_agrees_with_the_interpreter(program: Program, run) -> None:
    compiled = compile_program(program)
    firmware = ModelFirmware()
    interp = Interpreter(program, firmware=firmware)
    runner = ProgramRunner(
        LoadedProgram(compiled.code, compiled.pmap, compiled.entry_points), firmware=firmware
    )
    for cycle, (inputs, ticks, host_write) in enumerate(run):
        if ticks:
            interp.tick(ticks)
            runner.tick(ticks)
        if host_write is not None:
            n, value = host_write
            interp.state.flags[n] = value
            runner.write(Location(Space.XDATA, 0x200 + n), value)
        try:
            interp.cycle(inputs)
        except InterpreterTimeout:
            try:
                runner.cycle(inputs)
            except CycleTimeout:
                return
            raise AssertionError("the interpreter timed out, the compiled code did not") from None
        runner.cycle(inputs)
        _assert_same(interp, runner, compiled, cycle)
