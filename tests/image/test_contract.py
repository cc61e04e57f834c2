"""The runtime contract accepts every program the compiler makes.

``runtime.contract`` refuses images whose program map the firmware cannot run by
(tests/board/test_board_crafted_images.py has the crafted ones). It must never refuse
what asictl itself compiles, or a good program could not be downloaded: every demo,
every example of the manual, generated programs of every kind, and a program big
enough that its cells spill from internal RAM into XDATA.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import assume
from hypothesis import strategies as st
from il_strategies import assembly_sections, gatings, options_sections, programs, scopes
from manual_examples import EXAMPLES
from sized import check, sizes

from asictl.build import build, build_file, build_image
from asictl.codegen8051.compiler import compile_program
from asictl.il import ast
from asictl.il.checks import check_program
from asictl.il.loader import Program
from asictl.image.eeprom import ProgramImage
from asictl.runtime import contract, layout
from asictl.runtime.program_map import CellKind, LoadedProgram, Space
from asictl.source import from_string

ROOT = Path(__file__).resolve().parents[2]
DEMOS = sorted((ROOT / "demos").glob("*.asi"))
TABLE = layout.default_entry_points()


def assert_runnable(image: ProgramImage) -> None:
    """The contract holds, also for this firmware's table, and the bytes read back."""
    assert contract.problems(image.loaded_program(), TABLE) == []
    assert ProgramImage.from_bytes(image.to_bytes()) == image


@pytest.mark.parametrize("path", DEMOS, ids=lambda p: p.name)
def test_every_demo_keeps_the_contract(path: Path):
    built = build_file(path)
    assert built.image is not None, built.render()
    assert_runnable(built.image)


@pytest.mark.parametrize("name", EXAMPLES)
def test_every_manual_example_keeps_the_contract(name: str):
    built = build(from_string(f"{name}.asi", EXAMPLES[name]))
    assert built.image is not None, built.render()
    assert_runnable(built.image)


#: Every cell kind of every index a program can have, 17 timer-status groups, mapped and
#: plain counters and variables: more cells than internal RAM holds.
BIG = "\n".join([
    "[OPTIONS]",
    "map_counters: yes",
    "[DECL]",
    "Big BYTE 255",
    "Small BYTE 1",
    *(f"T{n} TIMER" for n in range(16, 1024, 8)),
    "C1000 COUNTER",
    "[PROGRAM]",
    *(f"  A I {s}.0\n  AN I2 {s}.1\n  = Q {s}.2" for s in range(32)),
    *(f"  A F {n}.0\n  = F {(n + 1) % 96}.1" for n in range(96)),
    "  L KT 100",
    *(f"  S T {n}\n  A T {n}\n  = F 126.0" for n in (0, *range(16, 1024, 8))),
    "  CU C 0\n  CU C 1000\n  L Big 254\n  T Small 0",
    "[END]",
])


def test_a_program_whose_cells_spill_into_xdata_keeps_the_contract():
    built = build(from_string("big.asi", BIG))
    assert built.image is not None, built.render()
    pmap = built.image.pmap
    spilled = {kind for (kind, _), where in pmap.cells.items() if where.space is Space.XDATA}
    assert spilled >= {CellKind.I, CellKind.I2, CellKind.TS}, spilled
    assert pmap.map_counters and pmap.counters[0] == layout.FLAGS_BASE + 96
    assert pmap.variables["big"].size == 255
    assert_runnable(built.image)


@st.composite
def generated_programs(draw: st.DrawFn) -> Program:
    """A main program of every section kind that compiles (ASM included, FB calls out)."""
    scope, decl = draw(scopes())
    decl = ast.DeclSection(tuple(d for d in decl.declarations if not isinstance(d, ast.FBDecl)))
    sections: list[ast.Section] = []
    if draw(st.booleans()):
        sections.append(draw(options_sections))
    sections.append(decl)
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.integers(0, 2))
        sections.append(
            draw(programs(scope)) if kind == 0 else draw(gatings(scope)) if kind == 1
            else draw(assembly_sections)
        )
    program = Program(main=ast.Module("main.asi", tuple(sections)))
    assume(not any(d.is_error for d in check_program(program)))
    return program


@sizes(100, 600)
def test_every_generated_program_keeps_the_contract(examples: int) -> None:
    check(examples, every_generated_program_keeps_the_contract,
          generated_programs())


def every_generated_program_keeps_the_contract(program: Program) -> None:
    compiled = compile_program(program)
    assert contract.problems(
        LoadedProgram(compiled.code, compiled.pmap, compiled.used_entry_points()), TABLE
    ) == []
    assert_runnable(build_image(compiled, with_source=False))


def test_the_first_problem_is_named_and_the_others_counted():
    blink = build_file(ROOT / "demos" / "blink.asi").image
    assert blink is not None
    program = blink.loaded_program()
    program.pmap.timers[0] = 0xFFFF
    program.pmap.data_end = 0x0FFF
    with pytest.raises(contract.ContractError) as refused:
        contract.check(program)
    assert str(refused.value) == "program data ends at 0FFFh; it lies in 1000h-7FFFh"
    program.pmap.data_end = 0x1012
    program.pmap.pseg = 0xFFF8
    with pytest.raises(contract.ContractError) as refused:
        contract.check(program)
    assert str(refused.value) == (
        "PSeg at FFF8h-10007h lies outside the program's data 1000h-1011h (and 1 more problem)"
    )
