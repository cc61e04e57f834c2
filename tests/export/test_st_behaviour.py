"""The exported Structured Text, executed (tests/export/st_machine.py, its own parser and
executor of the subset the export writes), agrees with the reference interpreter cycle by
cycle: every demo on generated inputs, and generated programs of every instruction kind.
The check of the ST's behaviour that an installed ST runtime would give, as far as this
executor reads ST as IEC 61131-3 does."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import pytest
from il_strategies import checked_programs, cycle_steps
from mapped_counter_writes import RUN, mapped_counter_writes
from sized import check, sizes
from st_machine import StMachine

from asictl.build import build_file
from asictl.export.check import Cycle, generated_runs
from asictl.export.st import export_st
from asictl.il.loader import Program
from asictl.il.oracle import Interpreter

DEMOS = Path(__file__).parents[2] / "demos"
#: the default run's sample, and the long run's (``-m slow``)
EXAMPLES = int(os.environ.get("ASICTL_EXPORT_EXAMPLES", "40"))
LONG_EXAMPLES = int(os.environ.get("ASICTL_EXPORT_EXAMPLES", "300"))


def _first_difference(program: Program, text: str, run: Sequence[Cycle]) -> str | None:
    machine, oracle = StMachine(text), Interpreter(program)
    timers = machine.globals["IL_T"].value
    for index, cycle in enumerate(run):
        oracle.tick(cycle.ticks)
        machine.clock_ms += 10 * cycle.ticks
        machine.images["I"][:] = cycle.inputs
        oracle.cycle(cycle.inputs)
        machine.cycle()
        state = oracle.state
        if bytes(machine.images["Q"]) != bytes(state.outputs):
            return f"cycle {index}: outputs {machine.images['Q'].hex()} != {state.outputs.hex()}"
        if bytes(machine.images["M"]) != bytes(state.flags):
            return f"cycle {index}: flags {machine.images['M'].hex()} != {state.flags.hex()}"
        for n, remaining in enumerate(timers):
            expected = state.timers.get(n, 0)
            if remaining != expected:
                return f"cycle {index}: T {n} is {remaining}, {expected} on the master"
    return None


@pytest.mark.parametrize("path", sorted(DEMOS.glob("*.asi")), ids=lambda p: p.name)
def test_each_demos_structured_text_behaves_as_the_master(path: Path) -> None:
    program = build_file(path).program
    assert program is not None
    text = export_st(path.name, program).render()
    for name, run in generated_runs(3, seed=11, length=40):
        assert _first_difference(program, text, run) is None, name


def test_a_wrong_translation_is_seen() -> None:
    program = build_file(DEMOS / "sequence.asi").program
    assert program is not None
    text = export_st("sequence.asi", program).render()
    wrong = text.replace("F0_0 := TRUE", "F0_0 := FALSE", 1)
    assert wrong != text
    start = bytes([0x60]) + bytes(15)  # I 1.1 and I 1.2: retracted, start
    assert _first_difference(program, wrong, [Cycle(start, 1)]) is not None
    assert _first_difference(program, text, [Cycle(start, 1)]) is None


def test_writes_to_the_bits_a_mapped_counter_keeps_at_0_change_nothing() -> None:
    """=, S, R, T FY and T FW on the upper bits of a mapped counter's high byte, read
    back in the same cycle: the ST writes none of them, as the master keeps them 0."""
    program = mapped_counter_writes()
    text = export_st("mapped_counter_writes.asi", program).render()
    assert "F119_5 :=" not in text and "F 119.5 stays 0 on the master" in text
    assert _first_difference(program, text, RUN) is None


@sizes(EXAMPLES, LONG_EXAMPLES)
def test_generated_programs_structured_text_behaves_as_the_master(examples: int) -> None:
    check(examples, generated_programs_structured_text_behaves_as_the_master,
          checked_programs(asm=False, options=True), cycle_steps(max_size=8))


def generated_programs_structured_text_behaves_as_the_master(
    program: Program, steps: list[tuple[bytes, int, object]],
) -> None:
    run = [Cycle(inputs, ticks) for inputs, ticks, _ in steps]
    text = export_st("main.asi", program).render()
    difference = _first_difference(program, text, run)
    assert difference is None, f"{difference}\n{text}"
