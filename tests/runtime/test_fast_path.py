"""The runner's fast path against its general path, on generated programs.

The fast path is what the emulated master runs: the copies around a cycle generated per
program (runtime.cycle_io) and the emulator's regions (mcs51.regions). The general path
walks the program map and translates blocks only. Hypothesis writes valid programs
(every instruction kind, ASM lines, forward jumps, user and firmware block calls, timers,
counters, variables, gating lines) and a run of cycles with random inputs, timer ticks
and host writes to the flags; after every cycle the whole machine must be the same on
both: internal RAM, SFRs, all 64 KB of XDATA, PC, instruction and cycle counts, the
output image, the cycle's duration, and the firmware calls in order.
"""

from __future__ import annotations

import os

from il_strategies import ModelFirmware, checked_programs, cycle_steps
from sized import check, sizes

from asictl.codegen8051.compiler import compile_program
from asictl.il.loader import Program
from asictl.runtime import layout
from asictl.runtime.program_map import LoadedProgram
from asictl.runtime.runner import CycleTimeout, ProgramRunner

#: the default run's sample, and the long run's (``-m slow``)
EXAMPLES = int(os.environ.get("ASICTL_DIFF_EXAMPLES", "60"))
LONG_EXAMPLES = int(os.environ.get("ASICTL_DIFF_EXAMPLES", "400"))


compiled_programs = checked_programs(asm=True, options=False)

steps = cycle_steps(max_size=12)


def machine(runner: ProgramRunner, firmware: ModelFirmware) -> tuple:
    cpu = runner.cpu
    return (
        bytes(cpu.iram), bytes(cpu.sfr), bytes(cpu.xdata.ram), cpu.pc, cpu.instructions,
        cpu.cycles, bytes(runner.outputs), bytes(runner.inputs), runner.last_cycles,
        tuple(firmware.log),
    )  # fmt: skip


@sizes(EXAMPLES, LONG_EXAMPLES)
def test_fast_and_general_paths_leave_the_same_machine(examples: int) -> None:
    check(examples, fast_and_general_paths_leave_the_same_machine,
          compiled_programs, steps)


def fast_and_general_paths_leave_the_same_machine(program: Program, run) -> None:
    compiled = compile_program(program)
    loaded = LoadedProgram(compiled.code, compiled.pmap, compiled.entry_points)
    sides = []
    for fast in (True, False):
        firmware = ModelFirmware()
        runner = ProgramRunner(loaded, firmware=firmware, fast=fast)
        runner.cpu.hot = 1  # regions from the first cycle on, not only once warm
        sides.append((runner, firmware))
    for cycle, (inputs, ticks, host_write) in enumerate(run):
        outcomes = []
        for runner, firmware in sides:
            if ticks:
                runner.tick(ticks)
            if host_write is not None:
                n, value = host_write
                runner.cpu.xdata.write(layout.FLAGS_BASE + n, value)
            try:
                runner.cycle(inputs)
                outcome: object = "cycle"
            except CycleTimeout as exc:
                outcome = str(exc)
            outcomes.append((outcome, machine(runner, firmware)))
        assert outcomes[0] == outcomes[1], f"after cycle {cycle}"
    fast_cpu = sides[0][0].cpu
    assert any(entry[3] == 2 for entry in fast_cpu._blocks.values()), "no region ran"
