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

from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from il_strategies import gatings, programs, scopes

from asictl.codegen8051.compiler import compile_program
from asictl.il import ast
from asictl.il.checks import check_program
from asictl.il.loader import Program
from asictl.runtime import layout
from asictl.runtime.program_map import LoadedProgram
from asictl.runtime.runner import CycleTimeout, ProgramRunner

EXAMPLES = int(os.environ.get("ASICTL_DIFF_EXAMPLES", "200"))


class LoggingFirmware:
    """Deterministic firmware blocks that note every call."""

    def __init__(self) -> None:
        self.log: list[tuple[str, bytes]] = []

    def call(self, name: str, pseg: bytearray) -> None:
        self.log.append((name, bytes(pseg)))
        h = (sum(pseg[:4]) * 7 + len(name)) & 0xFF
        pseg[0] = 0 if h % 3 else 0x80
        pseg[1] = (pseg[1] ^ h) & 0xFF
        pseg[2] = h


def _forward_only(section: ast.ProgramSection) -> ast.ProgramSection:
    """Backward jumps make endless loops; those run into the cycle budget on both paths
    alike but take long, so they are left out."""
    seen: set[str] = set()
    kept = []
    for statement in section.statements:
        if isinstance(statement, ast.Label):
            seen.add(statement.name.casefold())
        if isinstance(statement, ast.Jump) and statement.label.casefold() in seen:
            continue
        kept.append(statement)
    return ast.ProgramSection(tuple(kept))


@st.composite
def compiled_programs(draw: st.DrawFn) -> Program:
    scope, decl = draw(scopes())
    decl = ast.DeclSection(tuple(d for d in decl.declarations if not isinstance(d, ast.FBDecl)))
    names = draw(st.lists(st.sampled_from(["BlkA", "BlkB"]), unique=True, max_size=2))
    blocks = {
        name.casefold(): ast.Module(f"{name}.fb", (_forward_only(draw(programs(scope))),))
        for name in names
    }
    sections: list = [ast.DeclSection(
        (*decl.declarations, *(ast.FBDecl(n, f"{n}.fb") for n in names))
    )]
    for _ in range(draw(st.integers(1, 3))):
        if draw(st.integers(0, 3)):
            statements = list(_forward_only(draw(programs(scope))).statements)
            for name in names:
                call = ast.CallFB(draw(st.booleans()), name)
                statements.insert(draw(st.integers(1, max(1, len(statements)))), call)
            sections.append(ast.ProgramSection(tuple(statements)))
        else:
            sections.append(draw(gatings(scope)))
    program = Program(main=ast.Module("main.asi", tuple(sections)), blocks=blocks)
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
    max_size=12,
)


def machine(runner: ProgramRunner, firmware: LoggingFirmware) -> tuple:
    cpu = runner.cpu
    return (
        bytes(cpu.iram), bytes(cpu.sfr), bytes(cpu.xdata.ram), cpu.pc, cpu.instructions,
        cpu.cycles, bytes(runner.outputs), bytes(runner.inputs), runner.last_cycles,
        tuple(firmware.log),
    )  # fmt: skip


@settings(
    max_examples=EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
@given(compiled_programs(), steps)
def test_fast_and_general_paths_leave_the_same_machine(program: Program, run) -> None:
    compiled = compile_program(program)
    loaded = LoadedProgram(compiled.code, compiled.pmap, compiled.entry_points)
    sides = []
    for fast in (True, False):
        firmware = LoggingFirmware()
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
