"""A quick search for inputs on which a surviving mutant and its original differ, made
before the prover is asked whether the mutant is equivalent.

The prover can only prove a mutant equivalent; for one that is not (nearly every
survivor: a timer constant one step off, a neighbouring output that no scenario checks)
it searches until its time runs out, ten seconds a survivor. Running both programs'
compiled code side by side on the same inputs, drawn at random and held for random
stretches (a timer needs its input held to run out), with the master's 10 ms clock
ticking between the cycles as the prover models it, finds most such differences in a
fraction of that. Outputs that differ after some cycle make the two programs different
by the prover's own definition (the same outputs after every cycle, for every input
sequence and every phase of the clock), so the proof is not tried: the verdict is the
same, only sooner. Programs whose code depends on what this cannot give, the answers of
firmware blocks and anything [ASSEMBLY] code may read, are left to the prover.
"""

from __future__ import annotations

import random
import time
from dataclasses import dataclass

from asictl.build import Build
from asictl.il.oracle import runs_alone
from asictl.observe.names import named_bits
from asictl.observe.symbols import SymbolTable
from asictl.platform.master import TICK_US, asi_cycle_us
from asictl.runtime import layout
from asictl.runtime.runner import CycleTimeout, ProgramRunner

#: How many program cycles each search runs at most (both programs: twice as many).
CYCLES = 20_000
#: How much master time it covers at most, in microseconds: cycles that would repeat
#: the last exactly (inputs held, no tick due, memory left as it was) are not run.
MASTER_TIME_US = 300_000_000
#: How long a search may take, in seconds of wall time.
SECONDS = 2.0
#: The longest stretch an input is held, in microseconds (a timer runs out in 41 s).
LONGEST_HOLD_US = 45_000_000


@dataclass(frozen=True)
class Difference:
    """Where two programs were seen to differ: the output byte (slaves 2n and 2n+1), its
    value in the original and in the other, and when (ms of random inputs)."""

    output: int
    original: int
    other: int
    at_ms: int

    def describe(self, symbols: SymbolTable) -> str:
        """``not equivalent: Q 3.1 (PumpB) differs from the original's after 4986 ms of
        random inputs``: the bits that differ, named by the program's symbol table."""
        bits = named_bits(f"QB {2 * self.output}", self.original, self.other, symbols)
        shown = ", ".join(bit for bit, _, _ in bits)
        verb = "differs" if len(bits) == 1 else "differ"
        return (f"not equivalent: {shown} {verb} from the original's after {self.at_ms} ms "
                "of random inputs")


def find_difference(original: Build, mutant: Build, *, seed: int = 0,
                    budget_s: float = SECONDS) -> Difference | None:
    """The first cycle after which the two builds' outputs differ on one random run, or
    None when none did within the budget (or the programs cannot be searched so). The
    budget is wall time: a large program's cycles cost more, and what the search does
    not find the prover may still; either way no verdict changes, only how soon."""
    first, second = original.source_program(), mutant.source_program()
    if first is None or second is None or original.image is None or mutant.image is None \
            or not (runs_alone(first) and runs_alone(second)):
        return None
    bus = sorted({s.address for program in (first, second) for s in program.slaves})
    cycle_us = asi_cycle_us(len(bus))
    runners = [ProgramRunner(original.image.loaded_program()),
               ProgramRunner(mutant.image.loaded_program())]
    rng = random.Random(seed)
    until_tick = rng.randint(1, TICK_US)  # from the first cycle's start: the clock's phase
    inputs = bytearray(16)
    held = dict.fromkeys(bus, 0)  # how many more cycles each slave's inputs stay
    now = cycle = 0
    deadline = time.monotonic() + budget_s
    while cycle < CYCLES and now < MASTER_TIME_US:
        if cycle % 256 == 255 and time.monotonic() > deadline:
            return None
        for address in bus:
            if held[address] <= 0:
                nibble = rng.randrange(16)
                shift = (address & 1) * 4
                inputs[address >> 1] = inputs[address >> 1] & ~(0xF << shift) | nibble << shift
                hold_us = rng.randint(1, 5) * cycle_us if rng.random() < 0.5 else \
                    rng.randint(cycle_us, LONGEST_HOLD_US)
                held[address] = -(-hold_us // cycle_us)
        before = [_memory(runner) for runner in runners]
        try:
            for runner in runners:
                runner.cycle(inputs)
        except CycleTimeout:  # a loop the master would end: the prover's to judge
            return None
        cycle += 1
        ours, theirs = runners[0].outputs, runners[1].outputs
        if ours != theirs:
            byte = next(i for i in range(16) if ours[i] != theirs[i])
            return Difference(byte, ours[byte], theirs[byte], now // 1000)
        # the cycles before the next tick repeat this one if it changed nothing and no
        # input changes: they are not run
        repeats = 0
        if all(b == _memory(r) for b, r in zip(before, runners, strict=True)):
            repeats = min([(until_tick - 1) // cycle_us, *(held[a] - 1 for a in bus)])
        steps = 1 + max(0, repeats)
        for address in bus:
            held[address] -= steps
        now += steps * cycle_us
        until_tick -= steps * cycle_us
        ticks = 0  # the ticks until the next cycle starts (one at its start included)
        while until_tick <= 0:
            ticks += 1
            until_tick += TICK_US
        if ticks:
            for runner in runners:
                runner.tick(ticks)
    return None


def _memory(runner: ProgramRunner) -> bytes:
    """What a cycle of compiled IL can change: internal RAM, SFRs, the flags, the
    program's data, and the input image that becomes I2."""
    cpu, pmap = runner.cpu, runner.pmap
    xdata = cpu.xdata.ram
    return (bytes(cpu.iram) + bytes(cpu.sfr) + bytes(runner.inputs)
            + xdata[layout.FLAGS_BASE : layout.FLAGS_BASE + 128]
            + xdata[layout.DATA_BASE : pmap.data_end])
