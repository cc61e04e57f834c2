"""Counterexamples far behind timers and counters: the program run on input sequences of
few changes, each held for long stretches.

Behind the 1 h timer demo (100 runs of a 36 s timer counted by a counter) lies a
failure more than 200 steps deep even when each stretch of idle cycles is one step
(``prove/jump.py``): each run of the timer needs a cycle that counts and restarts it.
Bounded model checking cannot get there in seconds; running the program can. What
breaks such a property is mostly a simple input sequence: a button pressed and held, a
second one a while later. So the reference interpreter (``il/oracle.py``, the rules the
symbolic cycle is built from) runs the program from the reset, on the simulator's phase
of the 10 ms clock, on the input sequences with no change, one change, two, ... (breadth
first, so the first found has the fewest), each change one bit of an input in the
property's cone of influence, made before one of the cycles the run before it executed.
Each run goes up to the horizon the caller gives (``Machine.falsify``: ``--depth`` when
it is given, else the presets of the timers in the cone, their sum as they may run one
after the other, times the largest counter preset the program loads, past the depth).

**Idle stretches run in one go.** A cycle with the inputs held that leaves everything
but the timers as the cycle before it left it is *idle*, and so is every cycle after it
that sees each timer run, or not, as it did: each does the same (the program reads a
timer only as a bit: a program that loads a timer's word, or a property or assumption
that reads one, is run cycle by cycle). So the run jumps to the last such cycle before a
timer runs out, with the timers it does not store into counted down by the ticks of the
cycles jumped; the property's value cannot change meanwhile, and a response's wait only
grows (the jump ends before it would reach its limit). An hour at 10 ms cycles is some
300 cycles run, not 360,000.

What is found is only a candidate: the caller writes it as a scenario and replays it in
the simulator (``session.replays``), and reports it only if it fails there as it should
(a witness passes). A failure found so is real, but not necessarily the shortest; that
nothing is found proves nothing.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from asictl.il import ast
from asictl.il.language import COUNTER_FLAG_BASE, MAPPED_COUNTERS
from asictl.il.loader import Program
from asictl.il.oracle import Interpreter, PlcState
from asictl.observe.condition import Expr, holds
from asictl.observe.operands import Operand
from asictl.platform.master import TICK_US
from asictl.prove.correspond import cell_value, clock_after, run_cycle
from asictl.prove.jump import ticks_in_a_cycle
from asictl.prove.props import Kind, Property
from asictl.prove.symbolic import counter_high_bytes, operand_cells
from asictl.runtime.runner import CycleTimeout

K = ast.OperandKind
#: The most input changes a sequence has (unless the goal says).
MOST_CHANGES = 3
#: The most places (cycles) one run offers for the next change: spread over the run.
MOST_PLACES = 48
#: An input bit: ("in", slave, bit) or ("host", flag byte, bit).
Bit = tuple[str, int, int]


class _Written(dict[int, int]):
    """A timer table that remembers which timers a cycle stores into (``S``, ``R``, ``T``
    store even when the value stays): the timers it does not store into only count down,
    which is what a jump over idle cycles needs to know."""

    written: set[int]

    def __init__(self, *args: object) -> None:
        super().__init__(*args)
        self.written = set()

    def __setitem__(self, key: int, value: int) -> None:
        self.written.add(key)
        super().__setitem__(key, value)

    def __copy__(self) -> _Written:
        table = _Written(self)
        table.written = set(self.written)
        return table


@dataclass
class Goal:
    """What the runs look for, and what they may change."""

    prop: Property
    assume: list[Expr]
    #: the inputs the property depends on, the only ones changed
    bits: list[Bit]
    slaves: tuple[int, ...]
    host_masks: dict[int, int]
    cycle_us: int
    #: the simulator's time from time 0 to the first 10 ms tick
    phase_us: int
    #: a response's limit in cycles (0 for other kinds)
    window: int
    #: how many cycles a run goes to
    horizon: int
    #: whether idle stretches may be run in one go (no timer's word is read)
    jumps: bool
    #: the most input changes a sequence has
    changes: int = MOST_CHANGES


@dataclass
class Found:
    """An input sequence that breaks the property (or reaches it): the inputs of every
    cycle (each slave's four bits, each host flag byte), the state after the last one,
    and how many changes it took."""

    inputs: list[tuple[dict[int, int], dict[int, int]]]
    read: Callable[[Operand], int]
    changes: int


@dataclass
class _Place:
    """Before cycle ``cycle`` of a run (0 the first): the state, the time to the next
    tick, the response's wait, and the input values then."""

    cycle: int
    state: PlcState
    until_us: int
    wait: int | None
    values: dict[Bit, int]


@dataclass
class _Run:
    """Where one input sequence went: the cycles it ran past the change that made it,
    and where the next change may be made."""

    places: list[_Place] = field(default_factory=list)
    #: every how many executed cycles a place is kept (doubled as the list fills)
    stride: int = 1
    executed: int = 0


def reader(state: PlcState, map_counters: bool) -> Callable[[Operand], int]:
    """An operand's value as a scenario's ``expect`` reads it (``symbolic.operand_value``
    on the interpreter's state)."""
    def read(operand: Operand) -> int:
        node = operand.node
        kind, n = node.kind, node.address
        if kind is K.T:
            ticks = state.timers.get(n, 0)
            return ticks * 10 if node.width is ast.Width.WORD else int(ticks != 0)
        if kind is K.C:
            if map_counters and n < MAPPED_COUNTERS:
                flags = state.flags
                count = (flags[COUNTER_FLAG_BASE + 2 * n + 1] & 0x0F) << 8 | flags[
                    COUNTER_FLAG_BASE + 2 * n]
            else:
                count = state.counters.get(n, 0)
            return count if node.width is ast.Width.WORD else int(count != 0)
        byte = cell_value(state, operand_cells(node, map_counters)[0])
        if node.width is ast.Width.NIBBLE:
            return byte >> (n & 1) * 4 & 0xF
        if node.width is ast.Width.BIT:
            bit = (n & 1) * 4 + node.bit if kind in (K.I, K.I2, K.Q) else node.bit
            return byte >> bit & 1
        return byte
    return read


def _plain(state: PlcState) -> tuple[object, ...]:
    """Everything but the timers: what an idle cycle leaves as it found it."""
    return (bytes(state.inputs), bytes(state.old_inputs), bytes(state.outputs),
            bytes(state.flags), bytes(state.pseg), tuple(sorted(state.counters.items())),
            tuple((k, bytes(v)) for k, v in sorted(state.variables.items())),
            state.accu1, state.accu2, state.constant)


class _Search:
    def __init__(self, program: Program, goal: Goal, until: float) -> None:
        self.goal = goal
        self.until = until
        self.map_counters = program.options.map_counters
        self.machine = Interpreter(program, map_counters=self.map_counters)
        self.high = counter_high_bytes(program)
        self.most_ticks = ticks_in_a_cycle(goal.cycle_us)
        self.out_of_time = False

    def first(self) -> _Place:
        state = self.machine.state
        state.timers = _Written(state.timers)
        return _Place(0, state, self.goal.phase_us, None, dict.fromkeys(self.goal.bits, 0))

    def _images(self, values: dict[Bit, int]) -> tuple[bytes, dict[int, int]]:
        inputs = bytearray(16)
        host = dict.fromkeys(self.goal.host_masks, 0)
        for (kind, n, b), value in values.items():
            if not value:
                continue
            if kind == "in":
                inputs[n >> 1] |= 1 << ((n & 1) * 4 + b)
            else:
                host[n] |= 1 << b
        return bytes(inputs), host

    def _judge(self, read: Callable[[Operand], int], wait: int | None) -> tuple[
            int | None, bool]:
        """A response's wait after a cycle (None: none waits), and whether the property
        is broken (for ``reachable``: reached) there."""
        prop = self.goal.prop
        if prop.kind is Kind.RESPONSE:
            assert prop.then is not None
            if holds(prop.then, read):
                return None, False
            if wait is not None:
                wait += 1
            elif holds(prop.expr, read):
                wait = 0
            return wait, wait is not None and wait >= self.goal.window
        happened = holds(prop.expr, read)
        return None, happened != (prop.kind is Kind.ALWAYS)

    def run(self, place: _Place, record: bool, stop: int | None = None) -> tuple[
            _Run, int | None, _Place | None]:
        """The inputs of ``place`` held from there to the horizon (or to cycle ``stop``):
        the run's places, the cycle after which the property fails, if it does, and
        where the run ended (None: cut short, the sequence not one to go on with)."""
        goal = self.goal
        end = goal.horizon if stop is None else min(stop, goal.horizon)
        machine = self.machine
        state = machine.state = place.state.copy()
        timers = state.timers
        assert isinstance(timers, _Written)
        images, host = self._images(place.values)
        cycle, until, wait = place.cycle, place.until_us, place.wait
        run = _Run()
        before: tuple[object, ...] | None = None
        while cycle < end:
            run.executed += 1
            if run.executed % 32 == 0 and time.monotonic() > self.until:
                self.out_of_time = True
                return run, None, None
            if record and (run.executed - 1) % run.stride == 0:
                run.places.append(_Place(cycle, state.copy(), until, wait,
                                         place.values))
                if len(run.places) >= MOST_PLACES:  # keep every other one
                    run.places = run.places[::2]
                    run.stride *= 2
            running = {n: t != 0 for n, t in timers.items()}
            timers.written.clear()
            try:
                run_cycle(machine, images, host, goal.host_masks, self.high)
            except (CycleTimeout, KeyError, IndexError):
                return run, None, None  # a loop the master would stop
            read = reader(state, self.map_counters)
            wait, bad = self._judge(read, wait)
            if bad:
                return run, cycle, None
            if not all(holds(a, read) for a in goal.assume):
                return run, None, None  # an input sequence [assume] rules out
            after = _plain(state)
            if before == after and goal.jumps:
                jumped = self._idle(running, timers, until, end - cycle, wait)
                if jumped:
                    ticks, until = clock_after(until, jumped * goal.cycle_us)
                    for n in timers.keys() - timers.written:
                        timers[n] = max(0, timers[n] - ticks)
                    cycle += jumped
                    if wait is not None:
                        wait += jumped
            before = after
            ticks, until = clock_after(until, goal.cycle_us)
            if ticks:
                machine.tick(ticks)
            cycle += 1
        return run, None, _Place(cycle, state, until, wait, place.values)

    def _idle(self, running: dict[int, bool], timers: _Written, until: int, left: int,
              wait: int | None) -> int:
        """How many cycles after this idle one do the same as it (0: none is sure to):
        each sees every timer run, or not, as this one did, until the one before a timer
        runs out, and the one before the run's last (``left`` cycles from this one)."""
        goal = self.goal
        most = left - 2
        if wait is not None:
            most = min(most, goal.window - wait - 2)
        for n, ticks in timers.items():
            if n in timers.written:  # stored alike every cycle: its value must not matter
                if running.get(n, False) != (ticks != 0) or 0 < ticks <= self.most_ticks:
                    return 0
            elif ticks:  # counts down: runs while fewer ticks have passed than it holds
                last = -(-(until + (ticks - 1) * TICK_US) // goal.cycle_us) - 1
                most = min(most, last - 1)
        return max(0, most)

    def search(self) -> Found | None:
        """Breadth first over the input sequences of 0, 1, ... changes."""
        goal = self.goal
        level: deque[tuple[_Place, list[tuple[int, Bit]]]] = deque([(self.first(), [])])
        for changes in range(goal.changes + 1):
            following: deque[tuple[_Place, list[tuple[int, Bit]]]] = deque()
            seen: set[tuple[object, ...]] = set()
            while level:
                if time.monotonic() > self.until:
                    return None
                place, made = level.popleft()
                run, failed, _ = self.run(place, record=changes < goal.changes)
                if failed is not None:
                    return self._found(made, failed, changes)
                if self.out_of_time:
                    return None
                for later in run.places:
                    for bit in goal.bits:
                        values = dict(later.values)
                        values[bit] ^= 1
                        key = (later.cycle, tuple(values.values()), _plain(later.state),
                               tuple(sorted(later.state.timers.items())), later.until_us,
                               later.wait)
                        if key in seen:
                            continue
                        seen.add(key)
                        following.append((_Place(later.cycle, later.state, later.until_us,
                                                 later.wait, values),
                                          [*made, (later.cycle, bit)]))
            level = following
        return None

    def _found(self, made: list[tuple[int, Bit]], failed: int, changes: int) -> Found:
        """The inputs of every cycle up to ``failed`` (each held until it changes)."""
        values = dict.fromkeys(self.goal.bits, 0)
        inputs: list[tuple[dict[int, int], dict[int, int]]] = []
        at = 0
        for cycle, bit in [*made, (failed + 1, None)]:
            images, host = self._images(values)
            step = ({a: images[a >> 1] >> (a & 1) * 4 & 0xF for a in self.goal.slaves},
                    host)
            inputs += [step] * (cycle - at)
            at = cycle
            if bit is not None:
                values[bit] ^= 1
        return Found(inputs, reader(self.machine.state, self.map_counters), changes)


def first_failure(program: Program, goal: Goal, schedule: list[tuple[int, Bit]]) -> int | None:
    """The cycle after which ``goal.prop`` fails (is reached) on one input sequence,
    each (cycle, bit) of ``schedule`` a change of that bit before that cycle, or None
    within the horizon: the runs of one sequence, without a time limit."""
    search = _Search(program, goal, math.inf)
    place = search.first()
    for cycle, bit in [*sorted(schedule), (goal.horizon, None)]:
        _, failed, ended = search.run(place, record=False, stop=cycle)
        if ended is None:
            return failed
        place = ended
        if bit is not None:
            values = dict(place.values)
            values[bit] ^= 1
            place = dataclasses.replace(place, values=values)
    return None


def falsify(program: Program, goal: Goal, until: float) -> Found | None:
    """The input sequence of fewest changes (up to ``goal.changes``) found by
    ``time.monotonic() < until`` that breaks ``goal.prop`` within its horizon (reaches
    it, for ``reachable``), or None."""
    return _Search(program, goal, until).search()
