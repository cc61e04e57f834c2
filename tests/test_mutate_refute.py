"""quality/refute.py: the search that tells a survivor apart from its original before the
prover is asked. What it compares is what the prover's equivalence compares (timers and
counters too), and its counting run reaches the counts random inputs never do; each
difference it reports is checked against the reference interpreter (il/oracle.py), which
shares no code with the compiled programs it ran."""

from __future__ import annotations

from pathlib import Path

from asictl.build import Build, build_file
from asictl.diagnostics import DiagnosticError
from asictl.il.oracle import Interpreter
from asictl.observe.symbols import SymbolTable
from asictl.quality import mutate as mutation
from asictl.quality.refute import TOGGLE_CYCLES, find_difference

DEMOS = Path(__file__).resolve().parent.parent / "demos"


def _mutants(name: str) -> dict[str, Build]:
    """The mutants of a demo by their change, the first where a change repeats."""
    original = build_file(DEMOS / name)
    assert original.program is not None
    built = {}
    for mutant in mutation.mutants_of(original.program):
        try:
            built.setdefault(mutant.change, mutation.build_mutant(original, mutant))
        except DiagnosticError:
            continue
    return built


def _toggled_outputs(build: Build, slave: int, bit: int) -> list[bytes]:
    """The outputs after each cycle of the reference interpreter, one input bit toggling."""
    assert build.program is not None
    plc = Interpreter(build.program)
    seen = []
    for cycle in range(TOGGLE_CYCLES):
        inputs = bytearray(16)
        inputs[slave >> 1] = ((cycle & 1) << bit) << (slave & 1) * 4
        plc.cycle(bytes(inputs))
        seen.append(bytes(plc.state.outputs))
    return seen


def test_the_high_count_bits_are_told_apart_by_counting_and_the_oracle_agrees():
    """counter.asi reads bits 8-11 of its count (FY 97, map_counters); moving one of those
    reads to its neighbour changes Q 2.1 only at a count of 256 and more, which random
    inputs (loads, clears, ups and downs) never reach. The counting run does, and the
    reference interpreter, given the same toggling input, sees the outputs differ too."""
    original = build_file(DEMOS / "counter.asi")
    checked = 0
    for change, built in _mutants("counter.asi").items():
        if not change.startswith("O F 97.") or " -> O F 97." not in change:
            continue
        difference = find_difference(original, built, budget_s=60.0)
        assert difference is not None, change
        assert difference.toggled is not None, (change, str(difference))
        assert "toggling every cycle" in difference.describe(SymbolTable())
        ours = _toggled_outputs(original, *difference.toggled)
        theirs = _toggled_outputs(built, *difference.toggled)
        assert ours != theirs, change
        checked += 1
    assert checked == 4  # F 97.0 .. F 97.3, each moved up by one


def test_a_timer_preset_one_step_off_differs_from_the_cycle_the_timer_starts():
    """1h_timer.asi's 36 s presets one step off change its outputs only after the hour;
    the remaining time, which the prover compares too, differs from the start (the
    first preset, the one the rising edge of I 1.0 loads). The
    reference interpreter agrees: after the start and one tick, timer 7 differs."""
    original = build_file(DEMOS / "1h_timer.asi")
    assert original.program is not None
    mutants = _mutants("1h_timer.asi")
    for change in ("L KT 36000 -> L KT 35990", "L KT 36000 -> L KT 36010"):
        difference = find_difference(original, mutants[change], budget_s=60.0)
        assert difference is not None and difference.what == "T 7", (change, difference)
        remaining = []
        for build in (original, mutants[change]):
            assert build.program is not None
            plc = Interpreter(build.program)
            plc.cycle(bytes(16))
            plc.cycle(bytes([0x10]) + bytes(15))  # I 1.0 rises: the hour starts
            plc.tick()
            remaining.append(plc.state.timers[7])
        assert remaining[0] != remaining[1]


def test_an_equivalent_mutant_is_never_told_apart():
    """The search only ever says 'different': on the mutants the compiler turns into the
    original's code, it finds nothing, in either run."""
    original = build_file(DEMOS / "counter.asi")
    assert original.image is not None and original.compiled is not None
    same = [built for built in _mutants("counter.asi").values()
            if built.compiled is not None and built.compiled.code == original.compiled.code]
    for built in [original, *same]:
        assert find_difference(original, built, budget_s=60.0) is None
