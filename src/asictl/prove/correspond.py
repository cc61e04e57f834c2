"""Which state elements of two programs hold the same value: the candidates of the
relational invariant that proves a refactoring equivalent.

A refactoring (a flag, a timer or a counter renamed, networks moved, logic rewritten)
leaves the two programs' states corresponding element by element, often under other
names. Unrolling both programs cycle by cycle cannot prove that for ever; an invariant
that pairs the elements can: if every pair is equal after the first cycle, and one cycle
of both programs from any states with every pair equal keeps them equal, they are equal
after every cycle, and so are the outputs when the outputs follow from the pairs.

Which pairs? Running both programs (the reference interpreter, ``il/oracle.py``) on the
same random inputs, held for random stretches so that timers run out, and recording each
bit of every byte and each timer, counter and register after every cycle, shows which
element of one follows which element of the other: equal records (or, for bits,
complementary ones) make a candidate. They are only candidates: the prover keeps those
it proves (``Machine.find_invariants``, Houdini's algorithm), so a coincidence of the
random run costs a round of the solver, never a wrong verdict; and a pair that holds
in every run holds in this one too, so nothing true is left out, unless the run never
sets either element (then it is tried when both places are the program's own, a rename).

The same run may show the compared cells (the outputs, say) differ after some cycle.
That is a difference by the language's own rules, the reference interpreter's, from one
phase of the 10 ms clock the prover allows; it is told, with the run's inputs, only of
programs that run alone (``runs_alone``: the run gives no firmware answers), and it finds
what unrolling cannot reach: a timer one second shorter shows after hundreds of cycles.
"""

from __future__ import annotations

import random
import time
from collections.abc import Iterable
from dataclasses import dataclass, field

from asictl.il import ast
from asictl.il.ast import key
from asictl.il.loader import Program
from asictl.il.oracle import Interpreter, PlcState, runs_alone
from asictl.platform.master import TICK_US
from asictl.prove.scope import uses
from asictl.prove.symbolic import Key, counter_high_bytes, image_cell, width
from asictl.runtime.runner import CycleTimeout

K = ast.OperandKind
#: A state element: a cell and one of its bits, or -1 for the whole cell (a word).
Element = tuple[Key, int]

#: How many cycles of random inputs each program runs at most, and for how long.
CYCLES = 3000
SECONDS = 1.0
#: At most this many candidate pairs (a run that tells few elements apart).
MOST = 4000
#: How often an input is held for 1 to 5 cycles; else for as long as one of the timers
#: runs (``_holds``). Holds drawn from anything up to the longest timer (36 s: 3,600
#: cycles of 10 ms) left a program's one input slave unchanged through most of the run,
#: and an element that never changes is paired only at its own place.
SHORT = 0.75


@dataclass(frozen=True)
class Pair:
    """An element of the first program that may always equal one of the second (or its
    complement, ``inverted``)."""

    first: Element
    second: Element
    inverted: bool = False


def cell_value(state: PlcState, cell: Key) -> int:
    """A cell of the symbolic model (``prove/symbolic.py``) in the interpreter's state."""
    kind, n = cell[0], int(cell[-1]) if len(cell) > 1 else 0
    match kind:
        case "I" | "I2" | "Q" | "F" | "P":
            images = {"I": state.inputs, "I2": state.old_inputs, "Q": state.outputs,
                      "F": state.flags, "P": state.pseg}
            return images[kind][n]
        case "V":
            return state.variables[str(cell[1])][n]
        case "T":
            return state.timers.get(n, 0)
        case "C":
            return state.counters.get(n, 0)
        case "A1":
            return state.accu1 & 0xFFFF
        case "A2":
            return state.accu2 & 0xFFFF
        case "K":
            return state.constant & 0xFFFF
        case _:
            return 0


def _used(program: Program) -> set[Element]:
    """The elements a program's statements name: the bits it tests or writes, every bit
    of a byte it loads or transfers, its timers and counters. The input bits are among
    them: a flag that keeps an input for the next cycle (an edge's memory) then pairs
    with the input itself, which is what a network moved into the branch taken on
    that edge needs to be proved."""
    found: set[Element] = set()
    for operand, _ in uses(program):
        n, kind = operand.address, operand.kind
        if kind is K.F:
            found.add((("F", n), operand.bit))
        elif kind in (K.FY, K.FW):
            for byte in ast.flag_bytes(kind, n):
                found.update((("F", byte), bit) for bit in range(8))
        elif kind is K.VAR:
            cell: Key = ("V", key(operand.name), n)
            bits = [operand.bit] if operand.bit >= 0 else list(range(8))
            found.update((cell, bit) for bit in bits)
        elif kind in (K.T, K.C):
            found.add(((kind.value, n), -1))
        elif kind in (K.Q, K.QB, K.I, K.I2, K.IB, K.I2B):
            cell = image_cell(kind, n)
            bits = ([(n & 1) * 4 + operand.bit] if kind in (K.Q, K.I, K.I2)
                    else list(range(8)))
            found.update((cell, bit) for bit in bits)
    return found


def _holds(programs: Iterable[Program], cycle_us: int) -> list[int]:
    """How long, in program cycles, an input may be held on a long stretch: each timer
    time either program loads (the caller adds up to two cycles, so that the timer runs
    out within the stretch), at most a quarter of the run, and 10 cycles."""
    found = {10}
    for program in programs:
        for module in program.modules():
            for node in module.code():
                if isinstance(node, ast.Load) and node.operand.kind is K.KT:
                    found.add(min(CYCLES // 4, -(-node.operand.address * 1000 // cycle_us)))
    return sorted(found)


def run_cycle(machine: Interpreter, inputs: bytes, host: dict[int, int],
              host_masks: dict[int, int], high: tuple[int, ...]) -> None:
    """One program cycle as the master runs it: the host's writes to its flags first (the
    bits of ``host_masks``; a mapped counter's high byte, one of ``high``, keeps only bits
    0-3), then the program, after which the master clears bits 4-7 of those bytes."""
    flags = machine.state.flags
    for n, mask in host_masks.items():
        written = host[n] & 0x0F if n in high else host[n]
        flags[n] = flags[n] & ~mask & 0xFF | written & mask
    machine.cycle(inputs)
    for n in high:
        flags[n] &= 0x0F


@dataclass
class Run:
    """One random run of both programs: each one's cells after every cycle, and what the
    slaves and the host gave every cycle (each slave's four inputs, each host flag
    byte)."""

    records: tuple[list[list[int]], list[list[int]]] = field(default_factory=lambda: ([], []))
    steps: list[tuple[dict[int, int], dict[int, int]]] = field(default_factory=list)
    #: the compared cells (index in each program's cells) that differed after the last
    #: cycle; empty when none did
    differed: list[tuple[int, int]] = field(default_factory=list)


def _run(programs: tuple[Program, Program], cells: tuple[list[Key], list[Key]],
         compared: list[tuple[int, int]], *, slaves: tuple[int, ...], cycle_us: int,
         host_masks: dict[int, int], phase_us: int | None, seed: int,
         budget_s: float) -> Run:
    """Both programs on the same random inputs, until the budget is spent or the
    ``compared`` cells differ."""
    machines = [Interpreter(p, map_counters=p.options.map_counters) for p in programs]
    mapped = [counter_high_bytes(p) for p in programs]
    run = Run()
    rng = random.Random(seed)
    holds = _holds(programs, cycle_us)
    inputs = bytearray(16)
    held = dict.fromkeys(slaves, 0)
    host = dict.fromkeys(host_masks, 0)
    until_tick = phase_us if phase_us is not None else rng.randint(1, TICK_US)
    deadline = time.monotonic() + budget_s
    for cycle in range(CYCLES):
        if cycle % 64 == 63 and time.monotonic() > deadline:
            break
        for address in slaves:
            held[address] -= 1
            if held[address] <= 0:
                shift = (address & 1) * 4
                byte = address >> 1
                inputs[byte] = inputs[byte] & ~(0xF << shift) | rng.randrange(16) << shift
                held[address] = (rng.randint(1, 5) if rng.random() < SHORT
                                 else rng.choice(holds) + rng.randint(0, 2))
        for n in host:
            if rng.random() < 0.2:
                host[n] = rng.randrange(256)
        try:
            for machine, high, cellist, record in zip(machines, mapped, cells, run.records,
                                                      strict=True):
                run_cycle(machine, bytes(inputs), host, host_masks, high)
                record.append([cell_value(machine.state, cell) for cell in cellist])
        except (CycleTimeout, KeyError, IndexError):
            # a loop the master would stop, or a cell the interpreter lacks
            del run.records[0][cycle:], run.records[1][cycle:]
            break
        run.steps.append(({a: inputs[a >> 1] >> (a & 1) * 4 & 0xF for a in slaves},
                          dict(host)))
        first, second = run.records[0][-1], run.records[1][-1]
        run.differed = [(i, j) for i, j in compared if first[i] != second[j]]
        if run.differed:
            break
        ticks, until_tick = clock_after(until_tick, cycle_us)
        for machine in machines:
            machine.tick(ticks)
    return run


def clock_after(until_us: int, spent_us: int) -> tuple[int, int]:
    """The 10 ms ticks in the ``spent_us`` after a moment ``until_us`` before the next
    tick (one exactly at the end counts), and the time from the end to the next tick."""
    ticks = 0 if spent_us < until_us else (spent_us - until_us) // TICK_US + 1
    return ticks, until_us + ticks * TICK_US - spent_us


@dataclass
class Correspondence:
    """What a random run of both programs showed: the candidate pairs and, when the
    compared cells differed after some cycle, that cycle's run (the inputs of every
    cycle up to it, and each compared cell that differed with its two values)."""

    pairs: list[Pair]
    steps: list[tuple[dict[int, int], dict[int, int]]] = field(default_factory=list)
    differences: dict[tuple[Key, Key], tuple[int, int]] = field(default_factory=dict)


def corresponding(first: Program, second: Program, cells: tuple[list[Key], list[Key]], *,
                  compared: list[tuple[Key, Key]], slaves: tuple[int, ...], cycle_us: int,
                  host_masks: dict[int, int], phase_us: int | None = None, seed: int = 0,
                  budget_s: float = SECONDS) -> Correspondence:
    """Candidate pairs of elements of the two programs' ``cells`` (each program's own
    cells, as its symbolic cycle names them) that held the same value after every cycle
    of a random run of both; or the run that made a ``compared`` pair differ. A
    difference is told only for programs that run alone (``runs_alone``): the run gives
    no firmware answers, so it is not the master's run of programs that ask for them.
    ``phase_us`` is the time from the first cycle's start to the first 10 ms tick."""
    alone = runs_alone(first) and runs_alone(second)
    index = [{cell: n for n, cell in enumerate(cellist)} for cellist in cells]
    pairs = [(index[0][a], index[1][b]) for a, b in compared
             if a in index[0] and b in index[1]] if alone else []
    run = _run((first, second), cells, pairs, slaves=slaves, cycle_us=cycle_us,
               host_masks=host_masks, phase_us=phase_us, seed=seed, budget_s=budget_s)
    if run.differed:
        last = (run.records[0][-1], run.records[1][-1])
        return Correspondence([], run.steps, {
            (cells[0][i], cells[1][j]): (last[0][i], last[1][j]) for i, j in run.differed})
    if not run.records[0]:
        return Correspondence([])
    used = (_used(first), _used(second))
    either = used[0] | used[1]
    histories: list[dict[Element, tuple[int, ...]]] = []
    for cellist, record in zip(cells, run.records, strict=True):
        history: dict[Element, tuple[int, ...]] = {}
        for n, cell in enumerate(cellist):
            if cell[0] == "R":
                continue
            values = tuple(row[n] for row in record)
            history[(cell, -1)] = values
            if width(cell) == 8:
                history.update(((cell, bit), tuple(v >> bit & 1 for v in values))
                               for bit in range(8) if (cell, bit) in either)
        histories.append(history)
    return Correspondence(_pairs(histories[0], histories[1], used))


def _kind(element: Element) -> str:
    """What may pair with what: bits with bits, a word only with a word of its kind."""
    cell, bit = element
    return "bit" if bit >= 0 else f"word {cell[0]}"


def _pairs(first: dict[Element, tuple[int, ...]], second: dict[Element, tuple[int, ...]],
           used: tuple[set[Element], set[Element]]) -> list[Pair]:
    """Equal histories pair (complementary ones too, for bits that change); elements
    that never changed only at the same place, or when each is its own program's alone
    (a flag renamed that the run never set). Whole bytes pair at the same place, and
    their bits too, so that a byte one bit of which was renamed keeps the others."""
    found: list[Pair] = []
    by_history: dict[tuple[str, tuple[int, ...]], list[Element]] = {}
    for element, values in second.items():
        if not (width(element[0]) == 8 and element[1] < 0):
            by_history.setdefault((_kind(element), values), []).append(element)
    for element, values in sorted(first.items(), key=str):
        cell, bit = element
        if width(cell) == 8 and bit < 0:
            if second.get(element) == values:
                found.append(Pair(element, element))
            continue
        kind = _kind(element)
        constant = len(set(values)) <= 1
        for other in by_history.get((kind, values), []):
            if other == element or not constant or (
                    element in used[0] and element not in used[1]
                    and other in used[1] and other not in used[0]):
                found.append(Pair(element, other))
        if bit >= 0 and not constant:
            flipped = tuple(1 - v for v in values)
            found += [Pair(element, other, inverted=True)
                      for other in by_history.get((kind, flipped), [])]
    return found[:MOST]
