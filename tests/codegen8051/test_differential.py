"""The compiled code against the reference interpreter, on generated programs.

Hypothesis writes valid programs (every instruction kind, labels and forward jumps,
user and firmware block calls, timers, counters, byte and word operations, variables,
gating lines, map_counters) and a run of cycles with random inputs, host writes to the
flags (stored as the board stores them) and timer ticks in between. The 8051 code on the
emulator and the interpreter must agree on every output, flag, timer, counter, variable,
PSeg byte and IL register after every cycle.
"""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, given, settings
from il_strategies import ModelFirmware, checked_programs, cycle_steps

from asictl.codegen8051.compiler import compile_program
from asictl.il.loader import Program
from asictl.il.oracle import Interpreter
from asictl.platform.master import flag_keeps
from asictl.runtime.program_map import LoadedProgram, Location, Space
from asictl.runtime.runner import CycleTimeout, ProgramRunner

#: the default run's sample, and the long run's (``-m slow``)
EXAMPLES = int(os.environ.get("ASICTL_DIFF_EXAMPLES", "150"))
LONG_EXAMPLES = int(os.environ.get("ASICTL_DIFF_EXAMPLES", "1500"))


runnable_programs = checked_programs(asm=False, options=True)

steps = cycle_steps(max_size=8)


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


@settings(max_examples=EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(runnable_programs, steps)
def test_compiled_code_agrees_with_the_interpreter(program: Program, run) -> None:
    compiled_code_agrees_with_the_interpreter(program, run)


@pytest.mark.slow
@settings(max_examples=LONG_EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(runnable_programs, steps)
def test_compiled_code_agrees_with_the_interpreter_long(program: Program, run) -> None:
    compiled_code_agrees_with_the_interpreter(program, run)


def compiled_code_agrees_with_the_interpreter(program: Program, run) -> None:
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
            # as the board stores it: the upper four bits of a mapped counter's high byte
            # never reach it (Pc2Board.io_write), so neither side ever sees them
            n, value = host_write
            value &= flag_keeps(n, compiled.pmap.map_counters)
            interp.state.flags[n] = value
            runner.write(Location(Space.XDATA, 0x200 + n), value)
        try:
            interp.cycle(inputs)
        except CycleTimeout:
            try:
                runner.cycle(inputs)
            except CycleTimeout:
                return
            raise AssertionError("the interpreter timed out, the compiled code did not") from None
        runner.cycle(inputs)
        _assert_same(interp, runner, compiled, cycle)
