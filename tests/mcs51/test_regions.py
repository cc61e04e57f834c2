"""Regions (asictl.mcs51.regions), the emulator's fast path, against s51 and against the
interpreter.

A region replaces a block only once its address is hot (``Emulator.hot`` runs), so the
other emulator tests, which mostly run code once, see blocks. These tests make every
address hot at once (``hot = 1``) and check that regions really ran.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import random
from pathlib import Path
from types import ModuleType

import pytest
import test_emulator as emulator_tests
import test_ucsim_oracle as oracle
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from asictl.mcs51 import regions
from asictl.mcs51.emulator import Emulator, StopReason, exit_trap
from asictl.mcs51.isa import OPCODES

REGION = 2  # the translation cache's kind of a region entry


def region_emulator() -> Emulator:
    emu = Emulator()
    emu.hot = 1
    return emu


def regions_built(emu: Emulator) -> int:
    return sum(1 for entry in emu._blocks.values() if entry[3] == REGION)


def compare_with_s51(s51: str, cases: list[oracle.Case]) -> None:
    """Each case on s51 and on regions; at least most cases must have run a region."""
    emu = region_emulator()
    ours, watches, built = [], [], 0
    for case in cases:
        outcome, watch = oracle.run_ours(emu, case)
        ours.append(outcome)
        watches.append(watch)
        built += regions_built(emu) > 0
    assert built >= len(cases) // 2, f"only {built} of {len(cases)} cases ran a region"
    theirs = oracle.run_s51(s51, cases, watches)
    failures = [
        f"{case.label} @{case.pc:04X} {case.program.hex()}: {diff}"
        for case, mine, reference in zip(cases, ours, theirs, strict=True)
        if (diff := mine.differences(reference))
    ]
    assert not failures, f"{len(failures)} of {len(cases)} differ:\n" + "\n".join(failures[:40])


@pytest.mark.parametrize("states", [2, pytest.param(12, marks=pytest.mark.slow)])
def test_every_opcode_in_a_region_matches_s51(s51_path: str, states: int) -> None:
    """Each opcode, followed by SJMP $, from random states: the pair is one region (a
    jump, call or return ends it), with every byte it addresses directly in a local."""
    rng = random.Random(51)
    cases = [
        oracle.single_instruction_case(rng, opcode)
        for opcode, info in enumerate(OPCODES)
        if info is not None
        for _ in range(states)
    ]
    compare_with_s51(s51_path, cases)


@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(st.lists(oracle.programs(), min_size=8, max_size=8))
def test_random_sequences_with_forward_branches_match_s51(s51_path: str, cases) -> None:
    """Straight-line programs whose branches skip forward: each is one region with basic
    blocks joined by the branches, as a compiled PLC program is."""
    compare_with_s51(s51_path, cases)


def looping(case: oracle.Case) -> oracle.Case:
    """The drawn program with its final ``SJMP $`` jumping back to its start instead: a
    loop whose body branches forward (a superblock), run for a few rounds and stopped by
    the budget somewhere in a pass. A ``JC`` to the next instruction opens the body, so
    that even a body drawn without a branch has more than one basic block."""
    body = b"\x40\x00" + case.program[:-2]
    back = -(len(body) + 2) & 0xFF
    return dataclasses.replace(
        case, label="loop", program=body + bytes([0x80, back]), steps=3 * case.steps + 1
    )


@settings(
    max_examples=30,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(st.lists(oracle.programs().map(looping), min_size=8, max_size=8))
def test_loops_with_forward_branches_match_s51(s51_path: str, cases) -> None:
    """The same programs as loops: the region goes round inside its function while a
    whole pass fits the budget, and hands the rest to the blocks."""
    compare_with_s51(s51_path, cases)


# -- against the interpreter, with devices, breakpoints and budgets ----------------------

def programs() -> st.SearchStrategy[tuple[bytes, bytes, bytes, int, int | None]]:
    """The emulator tests' random programs (every opcode, computed RAM addresses, MOVX to
    devices, calls and returns), longer: regions grow over many instructions."""
    return emulator_tests.programs(max_opcodes=60)


def regions_and_interpreter_agree(monkeypatch: pytest.MonkeyPatch, case) -> None:
    """Small regions (so that they fit the budgets), every address hot: the same stops,
    state, and device accesses in the same order as the interpreter."""
    monkeypatch.setattr(regions, "MAX_REGION", 24)
    in_regions = emulator_tests.run_case(region_emulator(), case)
    assert in_regions == emulator_tests.run_case(Emulator(translate=False), case)


@settings(
    max_examples=15,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],  # the same patch each time
)
@given(programs())
def test_regions_and_interpreter_agree(monkeypatch: pytest.MonkeyPatch, case) -> None:
    regions_and_interpreter_agree(monkeypatch, case)


@pytest.mark.slow
@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(programs())
def test_regions_and_interpreter_agree_long(monkeypatch: pytest.MonkeyPatch, case) -> None:
    regions_and_interpreter_agree(monkeypatch, case)


def test_a_device_sees_the_bytes_a_region_keeps_in_locals() -> None:
    """A MOVX to a device in the middle of a region: the device reads internal RAM and
    writes it; the region stores its cached bytes before and loads them after."""
    # MOV 30h,#11h; MOV A,#5; MOVX @DPTR,A; INC 30h; MOV 31h,30h; SJMP $
    program = bytes.fromhex("753011 7405 f0 0530 853031 80fe")
    emu = region_emulator()
    emu.code.load(0x0200, program)
    seen = []

    def device(address: int, value: int) -> None:
        seen.append((address, value, emu.iram[0x30]))
        emu.iram[0x30] = 0x40

    emu.xdata.map(0x0000, 0x00FF, write=device)
    emu.pc = 0x0200
    assert emu.run(until=0x020B) is StopReason.UNTIL
    assert regions_built(emu) == 1
    assert seen == [(0x0000, 5, 0x11)]
    assert emu.iram[0x30] == emu.iram[0x31] == 0x41


@pytest.mark.parametrize("engine", ["region", "block"])
def test_a_device_sees_and_moves_the_dptr_translated_code_keeps_in_a_local(engine: str) -> None:
    """DPTR lives in a local of translated code: a device called through ``MOVX @R0``
    reads the value the code gave it and may change it, as in the interpreter."""
    # MOV DPTR,#1234h; INC DPTR; MOV R0,#5; MOVX @R0,A; INC DPTR; MOVX @DPTR,A; SJMP $
    program = bytes.fromhex("901234 a3 7805 f2 a3 f0 80fe")
    translated = region_emulator() if engine == "region" else Emulator(regions=False)
    results = []
    for emu in (translated, Emulator(translate=False)):
        emu.code.load(0x0100, program)
        seen = []

        def device(address: int, value: int, emu: Emulator = emu, seen: list = seen) -> None:
            seen.append((address, value, emu.dptr))
            emu.dptr = 0x2000

        emu.xdata.map(0xFF00, 0xFFFF, write=device)  # P2 is FFh: MOVX @R0 reaches FF05h
        emu.pc, emu.a = 0x0100, 0x5A
        assert emu.run(until=0x0109) is StopReason.UNTIL
        results.append((seen, emu.dptr, emu.xdata.ram[0x2001], emu.instructions, emu.cycles))
    assert results[0] == results[1] == ([(0xFF05, 0x5A, 0x1235)], 0x2001, 0x5A, 6, 11)
    assert regions_built(translated) == (engine == "region")


def test_a_region_is_used_only_once_its_address_is_hot() -> None:
    # MOV C,20h.0; ANL C,/20h.1; JNC +2; SETB 21h.0; RET
    program = bytes.fromhex("a200 b001 5002 d208 22")
    emu = Emulator()
    emu.code.load(0x0100, program)
    for run in range(1, Emulator.hot + 1):
        emu.sp = 0x07
        emu.push(0x00)
        emu.push(0x00)
        emu.pc = 0x0100
        emu.run(until=0x0000)
        assert regions_built(emu) == (1 if run == Emulator.hot else 0), run


def _benchmark() -> ModuleType:
    """benchmarks/bench_emulator.py, whose branchy program these tests run."""
    path = Path(__file__).parents[2] / "benchmarks" / "bench_emulator.py"
    spec = importlib.util.spec_from_file_location("bench_emulator", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


#: The benchmark's branchy program (a JNB and a JC in the inner loop's body), with small
#: counts: 1 outer round, 3 middle, 5 inner; the inner loop is a region whose function
#: goes round itself.
_BENCHMARK = _benchmark()
BRANCHY, BRANCHY_END = _BENCHMARK.nested(_BENCHMARK.BRANCHY, 1, 3, 5)
BRANCHY_LOOP, BRANCHY_SKIP = 0x09, 0x17  # L1, and the JNB's target


def branchy(emu: Emulator) -> Emulator:
    emu.code.load(0, BRANCHY)
    return restart(emu)


def restart(emu: Emulator) -> Emulator:
    """The branchy program's start state; the emulator keeps its translations."""
    emu.reset()
    emu.iram[:] = bytes(256)
    emu.xdata.ram[0x4000:0x4010] = bytes(range(0x70, 0x80))
    return emu


def machine(emu: Emulator) -> tuple:
    return (emu.pc, emu.instructions, emu.cycles, emu.psw, bytes(emu.iram), bytes(emu.sfr),
            bytes(emu.xdata.ram))  # fmt: skip


def test_a_loop_with_branches_goes_round_inside_its_region() -> None:
    """One call of the inner loop's region per start of that loop, not one per pass."""
    emu = branchy(region_emulator())
    assert emu.run(until=BRANCHY_END) is StopReason.UNTIL
    reference = branchy(Emulator(translate=False))
    reference.run(until=BRANCHY_END)
    assert machine(emu) == machine(reference)
    key = BRANCHY_LOOP  # register bank 0
    region, instructions, cycles, kind = emu._blocks[key]
    assert kind == REGION and region is not None
    calls = []
    emu._blocks[key] = (lambda *room: calls.append(room) or region(*room),
                        instructions, cycles, kind)  # fmt: skip
    restart(emu).run(until=BRANCHY_END)
    assert len(calls) == 3  # R6's three starts of the inner loop; R5 goes round 5 times in each
    assert machine(emu)[1:] == machine(reference)[1:]


@pytest.mark.parametrize("budget", ["instructions", "cycles"])
def test_every_budget_stops_a_looping_region_where_the_interpreter_stops(budget: str) -> None:
    """Every instruction and cycle budget over the whole run, resumed to the end: the
    loop's next pass starts inside the region only when all of it fits."""
    whole = branchy(Emulator(translate=False))
    whole.run(until=BRANCHY_END)
    total = whole.instructions if budget == "instructions" else whole.cycles
    ours, reference = branchy(region_emulator()), branchy(Emulator(translate=False))
    for limit in range(1, total + 2):
        for emu in (restart(ours), restart(reference)):
            emu.run(until=BRANCHY_END, **{f"max_{budget}": limit})
        assert machine(ours) == machine(reference), limit
        if ours.pc != BRANCHY_END:  # resuming there would run the SJMP $ once more
            assert ours.run(until=BRANCHY_END) is StopReason.UNTIL
        assert machine(ours) == machine(whole), limit


def test_a_breakpoint_in_a_looping_region_stops_every_pass() -> None:
    """A breakpoint on the JNB's target: each pass that reaches it stops there, with the
    counters the interpreter has."""
    ours, reference = branchy(region_emulator()), branchy(Emulator(translate=False))
    stops = []
    for emu in (ours, reference):
        emu.add_breakpoint(BRANCHY_SKIP)
        trail = []
        while (stop := emu.run(until=BRANCHY_END)) is StopReason.BREAKPOINT:
            trail.append(machine(emu))
        assert stop is StopReason.UNTIL
        stops.append(trail)
    assert len(stops[0]) == 15
    assert stops[0] == stops[1]



#: A program cycle's shape: forward branches only, then a jump to the firmware's return
#: address (an exit): MOV A,#5; JNB 20h.0,+1; INC A; MOV 30h,A; JB 20h.1,+2; INC 31h;
#: LJMP 00F0h.
FORWARD = bytes.fromhex("7405 300001 04 F530 200102 0531 0200F0")
FORWARD_END = 0x00F0
STACK = 0x07  # the stack pointer the caller leaves: the return address goes above it


def _exiting(program: bytes, end: int, emu: Emulator, trap=exit_trap) -> Emulator:
    """``program`` ending at an exit at ``end``, as a program cycle ends at the firmware's
    return address; every address hot and run once, so that its regions exist."""
    emu.code.load(0, program)
    emu.add_trap(end, trap)
    restart(emu).call(0, end, STACK, 1 << 20)
    return restart(emu)


@pytest.mark.parametrize("bit", [0, 1, 2, 3])
def test_a_call_that_is_one_region_to_an_exit_is_done_in_one_step(bit: int) -> None:
    """``call`` enters the region at the address and answers at the exit without
    ``run``'s loop; its answers and machine equal the interpreter's for every budget,
    those that end inside the region included (the loop goes on from there)."""
    ours = _exiting(FORWARD, FORWARD_END, region_emulator())
    loops = []
    ours._run = lambda *args, **kw: loops.append(args) or Emulator._run(ours, *args, **kw)
    reference = _exiting(FORWARD, FORWARD_END, Emulator(translate=False))
    for emu in (ours, reference):
        restart(emu).iram[0x20] = bit  # the branches: taken or not
    assert ours.call(0, FORWARD_END, STACK, 1 << 20) is StopReason.TRAP and not loops
    assert reference.call(0, FORWARD_END, STACK, 1 << 20) is StopReason.TRAP
    assert machine(ours) == machine(reference)
    assert ours.iram[STACK + 1] == FORWARD_END & 0xFF and ours.sp == STACK + 2  # pushed
    for limit in range(1, reference.cycles + 2):
        answers = []
        for emu in (ours, reference):
            restart(emu).iram[0x20] = bit
            answers.append(emu.call(0, FORWARD_END, STACK, limit))
        assert answers[0] is answers[1] and machine(ours) == machine(reference), limit
    assert loops, "a budget that ends inside the region goes on in the loop"


def test_a_call_of_regions_to_an_exit_answers_as_the_interpreter_for_every_budget() -> None:
    """The branchy program's loops: the region at the address ends before the exit, and
    the loop takes over from there."""
    ours = _exiting(BRANCHY, BRANCHY_END, region_emulator())
    reference = _exiting(BRANCHY, BRANCHY_END, Emulator(translate=False))
    assert reference.call(0, BRANCHY_END, STACK, 1 << 20) is StopReason.TRAP
    total = reference.cycles
    for limit in range(1, total + 2):
        answers = [restart(emu).call(0, BRANCHY_END, STACK, limit) for emu in (ours, reference)]
        assert answers[0] is answers[1] and machine(ours) == machine(reference), limit


def test_a_breakpoint_or_a_trap_that_goes_on_ends_the_one_step() -> None:
    """A breakpoint the region reaches, and a trap at its end that does not stop: the
    call answers as the interpreter does, and a run resumes from where it stopped."""
    calls = []

    def counting(emu: Emulator) -> bool:  # stops the second time only
        calls.append(emu.pc)
        return len(calls) % 2 == 0

    for setup in ("breakpoint", "trap"):
        machines = []
        for emu in (region_emulator(), Emulator(translate=False)):
            emu = _exiting(FORWARD, FORWARD_END, emu,
                           exit_trap if setup == "breakpoint" else counting)
            calls.clear()
            if setup == "breakpoint":
                emu.add_breakpoint(0x000B)  # INC 31h, reached with 20h.1 clear
            answers, seen = [], []
            for _ in range(3):  # from the start each time: the later calls take one step
                restart(emu)
                answers += [emu.call(0, FORWARD_END, STACK, 1 << 20),
                            emu.run(max_cycles=1 << 20)]
                seen.append(machine(emu))
            machines.append((answers, seen, list(calls)))
        assert machines[0] == machines[1], setup
        assert StopReason.BREAKPOINT in machines[0][0] if setup == "breakpoint" else calls
