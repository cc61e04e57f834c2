"""A quick search for inputs on which a surviving mutant and its original differ, made
before the prover is asked whether the mutant is equivalent.

The prover can only prove a mutant equivalent; for one that is not (nearly every
survivor: a timer constant one step off, a neighbouring output that no scenario checks)
it searches until its time runs out, five seconds a survivor. Running both programs'
compiled code side by side on the same inputs, with the master's 10 ms clock ticking
between the cycles as the prover models it, finds most such differences in a fraction
of that. Two runs are made. In the first the inputs are drawn at random and held for
random stretches (a timer needs its input held to run out). The second is for
counters: one input bit at a time toggles every cycle, the others held off, long
enough for a 12-bit counter to count through all its values (a bit of the count the
random run never reaches, FY 97 of a mapped counter, shows only there); it is made only
for programs with a counter, and toggles only the input bits they read.

What is compared after each cycle is what the prover's equivalence compares
(prove/diff.py, ``readable``): the outputs, the flag bytes, and the remaining time of
each timer and the count of each counter both programs have. A timer preset one step
off thus shows in the cycle its timer starts, not only when it runs out after an hour
of a scenario's time. Any such difference makes the two programs different by the
prover's own definition (the same on all of it after every cycle, for every input
sequence and every phase of the clock), so the proof is not tried: the verdict is the
same, only sooner.

A firmware block (GetLAS, ...) answers every call of both programs with the same 16
PSeg bytes, drawn once per run: the prover leaves each answer free, the same for both
programs call for call, and one answer for every call is one of the answers it allows.
Programs whose code depends on what this cannot give, PARAM's answer and its flag, and
anything [ASSEMBLY] code may read, are left to the prover.
"""

from __future__ import annotations

import random
import time
from dataclasses import dataclass

from asictl.build import Build
from asictl.il import ast
from asictl.il.loader import Program
from asictl.il.oracle import runs_alone
from asictl.observe.names import named_bits
from asictl.observe.symbols import SymbolTable
from asictl.platform.master import TICK_US, asi_cycle_us
from asictl.runtime import layout
from asictl.runtime.runner import CycleTimeout, ProgramRunner

#: How many program cycles the random run makes at most (both programs: twice as many).
CYCLES = 20_000
#: How much master time it covers at most, in microseconds: cycles that would repeat
#: the last exactly (inputs held, no tick due, memory left as it was) are not run.
MASTER_TIME_US = 300_000_000
#: How long each of the two runs may take, in seconds of this process's CPU time (not
#: wall time: on a loaded machine the search finds what it finds on an idle one).
SECONDS = 2.0
#: The longest stretch an input is held, in microseconds (a timer runs out in 41 s).
LONGEST_HOLD_US = 45_000_000
#: How many cycles one input bit toggles in the counting run: a rising edge every
#: second cycle takes a 12-bit counter through all 4,096 counts, with room to spare.
TOGGLE_CYCLES = 2 * 4096 + 16


@dataclass(frozen=True)
class Difference:
    """Where two programs were seen to differ: what (``QB 2``, ``FY 97``, ``T 7``), its
    value in the original and in the other (a byte's, to name the bits that differ),
    when (ms of the run), and on which inputs: random ones, or (slave, bit) toggling
    every cycle."""

    what: str
    original: int
    other: int
    at_ms: int
    toggled: tuple[int, int] | None = None

    def describe(self, symbols: SymbolTable) -> str:
        """``not equivalent: Q 3.1 (PumpB) differs from the original's after 4986 ms of
        random inputs``: the bits that differ (or the timer, the counter), named by the
        program's symbol table."""
        bits = named_bits(self.what, self.original, self.other, symbols)
        shown = ", ".join(bit for bit, _, _ in bits)
        verb = "differs" if len(bits) == 1 else "differ"
        inputs = "random inputs" if self.toggled is None else \
            "I {}.{} toggling every cycle".format(*self.toggled)
        return (f"not equivalent: {shown} {verb} from the original's after {self.at_ms} ms "
                f"of {inputs}")


@dataclass(frozen=True)
class _FixedAnswers:
    """Firmware whose every block answers with the same PSeg bytes."""

    answer: bytes

    def call(self, name: str, pseg: bytearray) -> None:
        pseg[:] = self.answer


class _Pair:
    """The original's and the mutant's compiled code run side by side, from reset, with
    the master's clock at a given phase."""

    def __init__(self, original: Build, mutant: Build, rng: random.Random) -> None:
        assert original.image is not None and mutant.image is not None
        firmware = _FixedAnswers(rng.randbytes(16))
        self.runners = [ProgramRunner(original.image.loaded_program(), firmware=firmware),
                        ProgramRunner(mutant.image.loaded_program(), firmware=firmware)]
        first, second = (runner.pmap for runner in self.runners)
        #: (name, address in the original's XDATA, in the mutant's, bytes)
        self.cells = [(f"T {n}", first.timers[n], second.timers[n], 2)
                      for n in sorted(first.timers.keys() & second.timers.keys())]
        self.cells += [(f"C {n}", first.counters[n], second.counters[n], 2)
                       for n in sorted(first.counters.keys() & second.counters.keys())]
        self.cells += [(v.name, v.address, second.variables[k].address, v.size)
                       for k, v in sorted(first.variables.items())
                       if k in second.variables and second.variables[k].size == v.size]
        self.until_tick = rng.randint(1, TICK_US)  # from the first cycle's start: the phase
        self.now = 0

    def cycle(self, inputs: bytearray) -> tuple[str, int, int] | None:
        """One cycle of both; what differs after it and its two values (None: nothing
        the prover compares). Raises ``CycleTimeout`` for a loop the master would end."""
        for runner in self.runners:
            runner.cycle(inputs)
        ours, theirs = (runner.outputs for runner in self.runners)
        if ours != theirs:
            n = next(i for i in range(16) if ours[i] != theirs[i])
            return f"QB {2 * n}", ours[n], theirs[n]
        a, b = (runner.cpu.xdata.ram for runner in self.runners)
        flags = slice(layout.FLAGS_BASE, layout.FLAGS_BASE + 128)
        if a[flags] != b[flags]:
            base = layout.FLAGS_BASE
            n = next(n for n in range(128) if a[base + n] != b[base + n])
            return f"FY {n}", a[base + n], b[base + n]
        for name, x, y, size in self.cells:
            if a[x : x + size] != b[y : y + size]:
                return (name, int.from_bytes(a[x : x + size], "little"),
                        int.from_bytes(b[y : y + size], "little"))
        return None

    def advance(self, steps: int, cycle_us: int) -> None:
        """``steps`` cycles' worth of master time, the ticks due in it given to both."""
        self.now += steps * cycle_us
        self.until_tick -= steps * cycle_us
        ticks = 0  # the ticks until the next cycle starts (one at its start included)
        while self.until_tick <= 0:
            ticks += 1
            self.until_tick += TICK_US
        if ticks:
            for runner in self.runners:
                runner.tick(ticks)

    def memory(self) -> list[bytes]:
        return [_memory(runner) for runner in self.runners]


def find_difference(original: Build, mutant: Build, *, seed: int = 0,
                    budget_s: float = SECONDS) -> Difference | None:
    """The first cycle after which the two builds differ in what the prover compares, on
    the random run or else the counting one; None when neither showed one within its
    budget (or the programs cannot be searched so). The budget is CPU time, each run's
    own: a large program's cycles cost more, and what the search does not find the
    prover may still; either way no verdict changes, only how soon."""
    first, second = original.source_program(), mutant.source_program()
    if first is None or second is None or original.image is None or mutant.image is None \
            or not (runs_alone(first, firmware_answers=True)
                    and runs_alone(second, firmware_answers=True)):
        return None
    bus = sorted({s.address for program in (first, second) for s in program.slaves})
    rng = random.Random(seed)
    try:
        return _random_run(original, mutant, bus, rng, time.process_time() + budget_s) or \
            _counting_run(original, mutant, bus, _counted_inputs(first, second), rng,
                          time.process_time() + budget_s)
    except CycleTimeout:  # a loop the master would end: the prover's to judge
        return None


def _random_run(original: Build, mutant: Build, bus: list[int], rng: random.Random,
                deadline: float) -> Difference | None:
    """Inputs drawn at random, each slave's held for a random stretch."""
    cycle_us = asi_cycle_us(len(bus))
    pair = _Pair(original, mutant, rng)
    inputs = bytearray(16)
    held = dict.fromkeys(bus, 0)  # how many more cycles each slave's inputs stay
    cycle = 0
    while cycle < CYCLES and pair.now < MASTER_TIME_US:
        if cycle % 256 == 255 and time.process_time() > deadline:
            return None
        for address in bus:
            if held[address] <= 0:
                _set_nibble(inputs, address, rng.randrange(16))
                hold_us = rng.randint(1, 5) * cycle_us if rng.random() < 0.5 else \
                    rng.randint(cycle_us, LONGEST_HOLD_US)
                held[address] = -(-hold_us // cycle_us)
        before = pair.memory()
        seen = pair.cycle(inputs)
        cycle += 1
        if seen is not None:
            return Difference(*seen, pair.now // 1000)
        # the cycles before the next tick repeat this one if it changed nothing and no
        # input changes: they are not run
        repeats = 0
        if before == pair.memory():
            repeats = min([(pair.until_tick - 1) // cycle_us, *(held[a] - 1 for a in bus)])
        steps = 1 + max(0, repeats)
        for address in bus:
            held[address] -= steps
        pair.advance(steps, cycle_us)
    return None


def _counted_inputs(*programs: Program) -> list[tuple[int, int]]:
    """The input bits (slave, bit) these programs read, if one of them has a counter:
    none otherwise (toggling an input finds nothing random inputs would not)."""
    operands = [operand for program in programs for module in program.modules()
                for section in module.sections for node in ast.nodes(section)
                if isinstance(node, ast.Statement | ast.GatingLine)
                for operand, _ in ast.operands(node)]
    if not any(o.kind is ast.OperandKind.C for o in operands):
        return []
    bits: set[tuple[int, int]] = set()
    for o in operands:
        if o.kind in (ast.OperandKind.I, ast.OperandKind.I2) and o.bit >= 0:
            bits.add((o.address, o.bit))
        elif o.kind in (ast.OperandKind.IB, ast.OperandKind.I2B):
            bits.update((2 * o.address + half, b) for half in (0, 1) for b in range(4))
    return sorted(bits)


def _counting_run(original: Build, mutant: Build, bus: list[int],
                  inputs_read: list[tuple[int, int]], rng: random.Random,
                  deadline: float) -> Difference | None:
    """Each input bit read in turn toggling every cycle from reset, the others off: a
    counter the bit counts runs through every count, up (or down from a preset)."""
    cycle_us = asi_cycle_us(len(bus))
    for address, bit in inputs_read:
        pair = _Pair(original, mutant, rng)
        inputs = bytearray(16)
        for cycle in range(TOGGLE_CYCLES):
            if cycle % 256 == 255 and time.process_time() > deadline:
                return None
            _set_nibble(inputs, address, (cycle & 1) << bit)
            seen = pair.cycle(inputs)
            if seen is not None:
                return Difference(*seen, pair.now // 1000, (address, bit))
            pair.advance(1, cycle_us)
    return None


def _set_nibble(inputs: bytearray, address: int, nibble: int) -> None:
    """Slave ``address``'s four input bits in the input image (two slaves a byte)."""
    shift = (address & 1) * 4
    inputs[address >> 1] = inputs[address >> 1] & ~(0xF << shift) | nibble << shift


def _memory(runner: ProgramRunner) -> bytes:
    """What a cycle of compiled IL can change: internal RAM, SFRs, the flags, the
    program's data, and the input image that becomes I2."""
    cpu, pmap = runner.cpu, runner.pmap
    xdata = cpu.xdata.ram
    return (bytes(cpu.iram) + bytes(cpu.sfr) + bytes(runner.inputs)
            + xdata[layout.FLAGS_BASE : layout.FLAGS_BASE + 128]
            + xdata[layout.DATA_BASE : pmap.data_end])
