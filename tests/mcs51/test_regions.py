"""Regions (asictl.mcs51.regions), the emulator's fast path, against s51 and against the
interpreter.

A region replaces a block only once its address is hot (``Emulator.hot`` runs), so the
other emulator tests, which mostly run code once, see blocks. These tests make every
address hot at once (``hot = 1``) and check that regions really ran.
"""

from __future__ import annotations

import random

import pytest
import test_emulator as emulator_tests
import test_ucsim_oracle as oracle
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from asictl.mcs51 import regions
from asictl.mcs51.emulator import Emulator, StopReason
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


def test_every_opcode_in_a_region_matches_s51(s51_path: str) -> None:
    """Each opcode, followed by SJMP $, from random states: the pair is one region (a
    jump, call or return ends it), with every byte it addresses directly in a local."""
    rng = random.Random(51)
    cases = [
        oracle.single_instruction_case(rng, opcode)
        for opcode, info in enumerate(OPCODES)
        if info is not None
        for _ in range(6)
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


# -- against the interpreter, with devices, breakpoints and budgets ----------------------

def programs() -> st.SearchStrategy[tuple[bytes, bytes, bytes, int, int | None]]:
    """The emulator tests' random programs (every opcode, computed RAM addresses, MOVX to
    devices, calls and returns), longer: regions grow over many instructions."""
    return emulator_tests.programs(max_opcodes=60)


@settings(
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],  # the same patch each time
)
@given(programs())
def test_regions_and_interpreter_agree(monkeypatch: pytest.MonkeyPatch, case) -> None:
    """Small regions (so that they fit the budgets), every address hot: the same stops,
    state, and device accesses in the same order as the interpreter."""
    monkeypatch.setattr(regions, "MAX_REGION", 24)
    in_regions = emulator_tests.run_case(region_emulator(), case)
    assert in_regions == emulator_tests.run_case(Emulator(translate=False), case)


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
