"""Plant models: inputs that react to the outputs, in virtual time (closed loop).

A scenario's ``[[plant]]`` tables (docs/simulation.md) and ``asictl.testing``'s
``Plc.add_plant`` make these models: a ``cylinder`` whose end switches follow its
stroke, a ``conveyor`` whose light barriers see the parts it carries, a ``tank`` whose
level switches follow its level, a ``motor`` with running feedback and an overload trip,
and a ``rule`` (a condition on operands that sets inputs after a delay) for the rest.

Every model keeps its time in whole microseconds (the simulation's resolution), so the
moment an end switch closes is exact and the same in every run. The simulation
evaluates the models after every AS-i cycle that ran (``update``: the state moves over
the time since the last evaluation as the outputs drove it then, then the outputs are
read and the inputs written), and asks each for the next moment one of its inputs would
change while the outputs stay as they are (``next_change``): cycles the master skips as
idle change no output, so evaluating the models at that moment, too, misses nothing.
An evaluation at T is applied as a scenario ``set`` at T is: the program cycle at T
sees it.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import ClassVar, Protocol

from asictl.il import ast
from asictl.observe.condition import Condition, ConditionError
from asictl.observe.operands import Operand, check_value
from asictl.readers.units import UnitError, duration_ms

#: The longest time a model takes (its stroke, a delay): a day, as the longest simulation.
MAX_MS = 24 * 3_600_000.0
#: How many parts a conveyor may carry at once (a scenario cannot flood the simulation).
MAX_PARTS = 10_000
#: How many barriers a conveyor, and level switches a tank, may have (each evaluation
#: looks at each, and each may change at its own moments).
MAX_SENSORS = 32
#: A time no simulation reaches, in microseconds (146,000 years): a model's moment
#: further off (a belt crawling at 1e-300 mm/s, whose run is an infinite float) is never.
NEVER_US = 2**62
K = ast.OperandKind


class PlantIO(Protocol):
    """What a model needs from the simulation: an operand's value now, and writing an
    input as a slave delivers it (or a flag as a host writes it)."""

    def read(self, operand: Operand) -> int: ...

    def write(self, operand: Operand, value: int) -> None: ...


@dataclass(frozen=True)
class Lane:
    """A model's state as a trace lane: its name, its width in bits, how to sample it."""

    name: str
    width: int
    sample: Callable[[], int]


def bits_of(operand: Operand) -> frozenset[tuple[str, int, int]]:
    """The input and flag bits an operand covers (``IB 4`` is slaves 4 and 5), to find
    two writers of one bit."""
    node = operand.node
    n, b = node.address, node.bit
    if node.kind is K.I:
        return frozenset({("I", n, b)} if b >= 0 else {("I", n, i) for i in range(4)})
    if node.kind is K.IB:
        return frozenset(("I", a, i) for a in (n, n + 1) for i in range(4))
    if node.kind is K.F:
        return frozenset({("F", n, b)})
    if node.kind is K.FY:
        return frozenset(("F", n, i) for i in range(8))
    return frozenset()


def _us(ms: float) -> int:
    return round(ms * 1000)


def _ceil_us(us: float) -> int:
    """``us`` rounded up to a whole microsecond, at most ``NEVER_US`` (an infinite or
    huge quotient of a tiny speed or rate has no integer)."""
    return math.ceil(us) if us < NEVER_US else NEVER_US


class Model:
    """One plant model; subclasses say what moves (``_advance``), what they read
    (``_sense``) and what they write (``_inputs``)."""

    kind: ClassVar[str]

    def __init__(self, name: str) -> None:
        self.name = name
        #: the line of its ``[[plant]]`` table (0: made in Python)
        self.line = 0
        #: the time of the last evaluation, in microseconds
        self._t = 0
        self._written: dict[str, int] = {}

    def driven(self) -> list[Operand]:
        """The inputs this model writes."""
        return [operand for operand, _ in self._inputs()]

    def sensed(self) -> list[Operand]:
        """The operands this model reads (after every cycle that runs)."""
        return []

    def lanes(self) -> list[Lane]:
        return []

    def update(self, now_ms: float, io: PlantIO) -> None:
        """Evaluate at ``now_ms``: move the state, read the outputs, write the inputs."""
        now = max(_us(now_ms), self._t)
        self._advance(now - self._t, now)
        self._t = now
        self._sense(io)
        for operand, value in self._inputs():
            key = str(operand)
            if self._written.get(key) != value:
                self._written[key] = value
                io.write(operand, value)

    def next_change(self) -> int | None:
        """The next microsecond, after the last evaluation, at which an input would
        change while the outputs stay as they are (None: never)."""
        return None

    @property
    def moving(self) -> bool:
        """Does a lane's value change between the input changes (a position, a level)?"""
        return False

    def _advance(self, dt: int, now: int) -> None:
        """The state ``dt`` microseconds later (``now`` is the new time)."""

    def _sense(self, io: PlantIO) -> None:
        """Read the outputs that drive the model from now on."""

    def _inputs(self) -> list[tuple[Operand, int]]:
        return []

    def _after(self, dt: float) -> int:
        """The microsecond ``dt`` microseconds after the last evaluation (at least one;
        a rounding error of a level's arithmetic does not make it the next one)."""
        return self._t + max(1, _ceil_us(dt - 1e-3))


class Cylinder(Model):
    """A pneumatic cylinder: ``extend`` drives it out over ``stroke_ms``; with a
    ``retract`` output it moves in only while that is on (and holds its position when
    neither or both are), without one a spring returns it while ``extend`` is off.
    ``extended`` is 1 at the end of the stroke, ``retracted`` only while fully in.
    ``position`` is the lane: percent of the stroke."""

    kind = "cylinder"

    def __init__(self, name: str, extend: Operand, stroke_ms: float, *,
                 retract: Operand | None = None, extended: Operand | None = None,
                 retracted: Operand | None = None) -> None:
        super().__init__(name)
        self.extend, self.retract = extend, retract
        self.extended, self.retracted = extended, retracted
        self.stroke = max(1, _us(stroke_ms))
        #: how far out, in microseconds of stroke (0: fully in)
        self.travel = 0
        self.direction = 0

    @property
    def position(self) -> float:
        """How far out, 0.0 (in) to 1.0 (the end of the stroke)."""
        return self.travel / self.stroke

    def sensed(self) -> list[Operand]:
        return [o for o in (self.extend, self.retract) if o is not None]

    def lanes(self) -> list[Lane]:
        return [Lane(f"{self.name} position", 7, lambda: round(100 * self.position))]

    def _advance(self, dt: int, now: int) -> None:
        self.travel = min(self.stroke, max(0, self.travel + self.direction * dt))

    def _sense(self, io: PlantIO) -> None:
        out = io.read(self.extend) != 0
        back = io.read(self.retract) != 0 if self.retract is not None else not out
        self.direction = 1 if out and not back else -1 if back and not out else 0

    def _inputs(self) -> list[tuple[Operand, int]]:
        found = []
        if self.extended is not None:
            found.append((self.extended, int(self.travel >= self.stroke)))
        if self.retracted is not None:
            found.append((self.retracted, int(self.travel <= 0)))
        return found

    @property
    def moving(self) -> bool:
        return (self.direction > 0 and self.travel < self.stroke) or (
            self.direction < 0 and self.travel > 0)

    def next_change(self) -> int | None:
        if self.direction > 0 and self.travel < self.stroke:
            return self._after(1 if self.travel == 0 else self.stroke - self.travel)
        if self.direction < 0 and self.travel > 0:
            return self._after(1 if self.travel == self.stroke else self.travel)
        return None


@dataclass(frozen=True)
class Barrier:
    """A light barrier: ``input`` is 1 while a part is within ``part_mm`` past ``at_mm``."""

    input: Operand
    at_mm: float


class Conveyor(Model):
    """A belt of ``length_mm`` moving at ``speed_mm_s`` while ``motor`` is on; parts are
    put on at 0 mm at the times ``parts_at_ms`` and on each rising edge of ``part_on``,
    and leave at the end. Lanes: the parts on the belt, and the position of the one
    furthest along (mm).

    The belt keeps its own run and each part the run at which it was put on, so moving
    is one addition and a barrier's next change a search, whatever the number of parts
    (each part's run once moved one by one, and every edge of every part was a moment to
    evaluate: 10,000 parts under many barriers took hours). The gaps between parts never
    change while they ride; a barrier stays covered over the parts that follow one
    another less than its width apart, so each width keeps where such a chain breaks."""

    kind = "conveyor"

    def __init__(self, name: str, motor: Operand, length_mm: float, speed_mm_s: float, *,
                 parts_at_ms: Iterable[float] = (), part_on: Operand | None = None,
                 barriers: Iterable[Barrier] = (), part_mm: float = 50.0) -> None:
        super().__init__(name)
        self.motor, self.part_on = motor, part_on
        self.speed = speed_mm_s
        self.barriers = list(barriers)
        self.part_mm = part_mm
        self.length = self._run(length_mm)
        self._edges = [(self._run(b.at_mm), self._run(b.at_mm + part_mm)) for b in self.barriers]
        self._arrivals = sorted({_us(t) for t in parts_at_ms}, reverse=True)
        #: the microseconds the belt has moved
        self._belt = 0
        #: the belt's run when each part was put on, oldest first; those before
        #: ``_head`` have left
        self._put_at: list[int] = []
        self._head = 0
        #: a barrier's width -> the parts (indices into ``_put_at``) that trail the one
        #: before by more than it
        self._breaks: dict[int, list[int]] = {end - start: [] for start, end in self._edges}
        self.delivered = 0
        self.running = False
        self._part_on = False

    @property
    def parts(self) -> list[int]:
        """Each part's run, the microseconds the belt moved since it was put on; the
        one furthest along first."""
        return [self._run_of(i) for i in range(self._head, len(self._put_at))]

    def _run_of(self, index: int) -> int:
        return self._belt - self._put_at[index]

    def _run(self, mm: float) -> int:
        """The belt's run in microseconds that carries a part ``mm`` far."""
        return _ceil_us(mm * 1_000_000 / self.speed - 1e-6)

    def position_mm(self, run: int) -> float:
        return run * self.speed / 1_000_000

    def sensed(self) -> list[Operand]:
        return [o for o in (self.motor, self.part_on) if o is not None]

    def lanes(self) -> list[Lane]:
        return [
            Lane(f"{self.name} parts", 16, lambda: len(self._put_at) - self._head),
            Lane(f"{self.name} position", 16, lambda: round(self.position_mm(
                self._run_of(self._head))) if self._on_belt() else 0),
        ]

    def _on_belt(self) -> bool:
        return self._head < len(self._put_at)

    def _put(self) -> None:
        count = len(self._put_at) - self._head
        if count >= MAX_PARTS:
            return
        if count:
            gap = self._run_of(-1)
            for width, breaks in self._breaks.items():
                if gap > width:
                    breaks.append(len(self._put_at))
        self._put_at.append(self._belt)

    def _advance(self, dt: int, now: int) -> None:
        if self.running:
            self._belt += dt
        while self._arrivals and self._arrivals[-1] <= now:
            self._arrivals.pop()
            self._put()
        head = self._head
        while head < len(self._put_at) and self._run_of(head) >= self.length:
            head += 1
        self.delivered += head - self._head
        self._head = head
        if head > 1024 and 2 * head > len(self._put_at):  # forget the parts that left
            del self._put_at[:head]
            for width, breaks in self._breaks.items():
                self._breaks[width] = [i - head for i in breaks if i > head]
            self._head = 0

    def _sense(self, io: PlantIO) -> None:
        self.running = io.read(self.motor) != 0
        if self.part_on is not None:
            on = io.read(self.part_on) != 0
            if on and not self._part_on:
                self._put()
            self._part_on = on

    def _furthest_short_of(self, run: int) -> int:
        """The index of the part furthest along whose run is short of ``run`` (the
        length of ``_put_at``: none is)."""
        return bisect.bisect_right(self._put_at, self._belt - run, lo=self._head)

    def _inputs(self) -> list[tuple[Operand, int]]:
        found = []
        for barrier, (start, end) in zip(self.barriers, self._edges, strict=True):
            i = self._furthest_short_of(end)
            covered = i < len(self._put_at) and self._run_of(i) >= start
            found.append((barrier.input, int(covered)))
        return found

    @property
    def moving(self) -> bool:
        return self.running and self._on_belt()

    def next_change(self) -> int | None:
        times = [self._arrivals[-1]] if self._arrivals else []
        if self.running and self._on_belt():
            times.append(self._after(self.length - self._run_of(self._head)))
            times += [self._after(run) for start, end in self._edges
                      if (run := self._barrier_change(start, end)) is not None]
        return min(times, default=None)

    def _barrier_change(self, start: int, end: int) -> int | None:
        """How much further the belt runs until the barrier seeing ``[start, end)``
        changes (None: never): a free one is covered when the part nearest short of it
        reaches ``start``; a covered one is free when the chain of parts in it and
        closing up behind it has passed ``end``."""
        i = self._furthest_short_of(end)
        if i == len(self._put_at):
            return None
        if self._run_of(i) < start:
            return start - self._run_of(i)
        breaks = self._breaks[end - start]
        j = bisect.bisect_right(breaks, i)
        last = breaks[j] - 1 if j < len(breaks) else len(self._put_at) - 1
        return end - self._run_of(last)


@dataclass(frozen=True)
class Switch:
    """A level switch: ``input`` is 1 while the level is at ``at`` or above."""

    input: Operand
    at: float


class Tank(Model):
    """A tank of ``capacity`` (units of the user's choice: litres, percent) that rises by
    ``fill_rate`` per second while ``fill`` is on and falls by ``drain_rate`` while
    ``drain`` is on; its level switches close at their levels. Lane: the level."""

    kind = "tank"

    def __init__(self, name: str, *, fill: Operand | None = None, fill_rate: float = 0.0,
                 drain: Operand | None = None, drain_rate: float = 0.0, level: float = 0.0,
                 capacity: float = 100.0, switches: Iterable[Switch] = ()) -> None:
        super().__init__(name)
        self.fill, self.drain = fill, drain
        self.fill_rate, self.drain_rate = fill_rate, drain_rate
        self.capacity = capacity
        self.level = min(max(level, 0.0), capacity)
        self.switches = list(switches)
        self.rate = 0.0  # per microsecond

    def sensed(self) -> list[Operand]:
        return [o for o in (self.fill, self.drain) if o is not None]

    def lanes(self) -> list[Lane]:
        return [Lane(f"{self.name} level", 16, lambda: round(self.level))]

    def _advance(self, dt: int, now: int) -> None:
        level = self.level + self.rate * dt
        for switch in self.switches:  # a level reached exactly, not a rounding error off
            if abs(level - switch.at) < 1e-9:
                level = switch.at
        self.level = min(max(level, 0.0), self.capacity)

    def _sense(self, io: PlantIO) -> None:
        rate = 0.0
        if self.fill is not None and io.read(self.fill):
            rate += self.fill_rate
        if self.drain is not None and io.read(self.drain):
            rate -= self.drain_rate
        self.rate = rate / 1_000_000

    def _inputs(self) -> list[tuple[Operand, int]]:
        return [(s.input, int(self.level >= s.at)) for s in self.switches]

    @property
    def moving(self) -> bool:
        return (self.rate > 0 and self.level < self.capacity) or (self.rate < 0 and self.level > 0)

    def next_change(self) -> int | None:
        times = []
        for switch in self.switches:
            gap = switch.at - self.level
            if self.rate > 0 and 0 < gap <= self.capacity - self.level:
                times.append(self._after(gap / self.rate))
            elif self.rate < 0 and gap <= 0 and switch.at > 0:
                times.append(self._after(gap / self.rate + 1))  # once below it
        return min(times, default=None)


class Motor(Model):
    """A motor on a contactor: ``running`` is 1 from ``start_ms`` after ``contactor``
    closes until it opens; at ``trip_at_ms`` the overload relay trips (``overload``
    goes to 1, the motor stops) and stays tripped. Lane: 0 off, 1 starting, 2 running,
    3 tripped."""

    kind = "motor"

    def __init__(self, name: str, contactor: Operand, *, running: Operand | None = None,
                 start_ms: float = 0.0, overload: Operand | None = None,
                 trip_at_ms: float | None = None) -> None:
        super().__init__(name)
        self.contactor, self.running_input, self.overload = contactor, running, overload
        self.start = _us(start_ms)
        self.trip_at = None if trip_at_ms is None else _us(trip_at_ms)
        self.on_since: int | None = None
        self.tripped = False

    @property
    def state(self) -> int:
        if self.tripped:
            return 3
        if self.on_since is None:
            return 0
        return 2 if self._t - self.on_since >= self.start else 1

    def sensed(self) -> list[Operand]:
        return [self.contactor]

    def lanes(self) -> list[Lane]:
        return [Lane(f"{self.name} state", 2, lambda: self.state)]

    def _advance(self, dt: int, now: int) -> None:
        if self.trip_at is not None and now >= self.trip_at:
            self.tripped = True

    def _sense(self, io: PlantIO) -> None:
        on = io.read(self.contactor) != 0
        if not on:
            self.on_since = None
        elif self.on_since is None:
            self.on_since = self._t

    def _inputs(self) -> list[tuple[Operand, int]]:
        found = []
        if self.running_input is not None:
            found.append((self.running_input, int(self.state == 2)))
        if self.overload is not None:
            found.append((self.overload, int(self.tripped)))
        return found

    def next_change(self) -> int | None:
        times = []
        if self.trip_at is not None and not self.tripped:
            times.append(max(self.trip_at, self._t + 1))
        if self.on_since is not None and not self.tripped and self.state == 1:
            times.append(max(self.on_since + self.start, self._t + 1))
        return min(times, default=None)


class Rule(Model):
    """``set`` once ``when`` has held for ``after_ms``; ``else`` as soon as it does not
    (without ``else`` the inputs keep their values). Lane: 1 while the rule is in
    force."""

    kind = "rule"

    def __init__(self, name: str, when: Condition, values: Mapping[Operand, int], *,
                 after_ms: float = 0.0, otherwise: Mapping[Operand, int] | None = None) -> None:
        super().__init__(name)
        self.when = when
        self.values = dict(values)
        self.otherwise = dict(otherwise or {})
        self.after = _us(after_ms)
        self.since: int | None = None
        self.active = False
        self._current: dict[Operand, int] = {}

    def driven(self) -> list[Operand]:
        return list({**self.values, **self.otherwise})

    def sensed(self) -> list[Operand]:
        return list(self.when.operands)

    def lanes(self) -> list[Lane]:
        return [Lane(f"{self.name} active", 1, lambda: int(self.active))]

    def _advance(self, dt: int, now: int) -> None:
        if self.since is not None and now - self.since >= self.after and not self.active:
            self.active = True
            self._current.update(self.values)

    def _sense(self, io: PlantIO) -> None:
        holds = self.when(io.read)
        if holds and self.since is None:
            self.since = self._t
            self._advance(0, self._t)
        elif not holds:
            self.since = None
            if self.active or not self._current:
                self._current.update(self.otherwise)
            self.active = False

    def _inputs(self) -> list[tuple[Operand, int]]:
        return list(self._current.items())

    def next_change(self) -> int | None:
        if self.since is not None and not self.active:
            return max(self.since + self.after, self._t + 1)
        return None


@dataclass
class Plant:
    """The models of one simulation, evaluated together."""

    models: list[Model] = field(default_factory=list)

    def add(self, model: Model) -> Model:
        """Add a model; ``ValueError`` if it writes an input twice or one another model
        writes, or has another's name (its trace lanes would be two lanes of one name)."""
        mine: dict[tuple[str, int, int], Operand] = {}
        for operand in model.driven():
            for bit in bits_of(operand):
                if bit in mine:
                    raise ValueError(f"'{operand}' is driven twice by {model.name}")
                mine[bit] = operand
        for other in self.models:
            if other.name == model.name:
                raise ValueError(f"a plant model is named '{model.name}' already")
            for operand in other.driven():
                for bit in bits_of(operand):
                    if bit in mine:
                        raise ValueError(f"'{mine[bit]}' is driven by {other.name} already")
        self.models.append(model)
        return model

    def driver_of(self, operand: Operand) -> Model | None:
        """The model that writes (part of) ``operand``, if any."""
        bits = bits_of(operand)
        for model in self.models:
            if any(bits & bits_of(o) for o in model.driven()):
                return model
        return None

    def update(self, now_ms: float, io: PlantIO) -> None:
        for model in self.models:
            model.update(now_ms, io)

    def next_change_ms(self, sample_ms: float | None = None) -> float | None:
        """The next moment a model's input would change, in milliseconds (None: never);
        with ``sample_ms``, also ``sample_ms`` after the last evaluation while a model is
        moving, so that a trace draws its position or level as it goes."""
        times = [t for m in self.models if (t := m.next_change()) is not None]
        if sample_ms is not None:
            times += [m._t + round(sample_ms * 1000) for m in self.models if m.moving]
        return min(times) / 1000 if times else None

    def lanes(self) -> list[Lane]:
        return [lane for model in self.models for lane in model.lanes()]


# ---------------------------------------------------------------------- tables


class Place(Protocol):
    """Where a table came from, for its problems: ``problem`` reports one at a key of the
    table (None: the table itself), ``condition_problem`` one inside the condition a key
    holds; ``operand`` and ``condition`` read texts as the scenario reads operands
    (symbols and variables too), raising ``ValueError`` (``ConditionError``)."""

    def problem(self, message: str, key: str | None = None) -> None: ...

    def condition_problem(self, error: ConditionError, key: str) -> None: ...

    def operand(self, text: str) -> Operand: ...

    def condition(self, text: str) -> Condition: ...


_KEYS: dict[str, dict[str, bool]] = {  # type -> key -> required
    "cylinder": {"extend": True, "retract": False, "extended": False, "retracted": False,
                 "stroke_ms": True},
    "conveyor": {"motor": True, "length_mm": True, "speed_mm_s": True, "parts_at_ms": False,
                 "part_on": False, "barriers": False, "part_mm": False},
    "tank": {"fill": False, "fill_rate": False, "drain": False, "drain_rate": False,
             "level": False, "capacity": False, "switches": False},
    "motor": {"contactor": True, "running": False, "start_ms": False, "overload": False,
              "trip_at_ms": False},
    "rule": {"when": True, "after_ms": False, "set": True, "else": False},
}
#: The types of model a ``[[plant]]`` table may have.
TYPES = tuple(_KEYS)


class _Bad(Exception):
    """One problem in a table, already reported."""


class _Table:
    def __init__(self, data: Mapping[str, object], place: Place,
                 written: Mapping[str, str] | None = None) -> None:
        self.data = data
        self.place = place
        #: key -> the key the file wrote it as (``stroke`` for ``stroke_ms``)
        self.written = written or {}

    def fail(self, message: str, key: str | None) -> _Bad:
        self.place.problem(message, self.written.get(key, key) if key else None)
        return _Bad()

    def operand(self, key: str, *, output: bool) -> Operand | None:
        if key not in self.data:
            return None
        text = self.data[key]
        if not isinstance(text, str):
            raise self.fail(f"{key} is an operand such as \"{'Q 2.0' if output else 'I 1.0'}\"",
                            key)
        return self._operand(text, key, output=output)

    def _operand(self, text: str, key: str, *, output: bool) -> Operand:
        try:
            operand = self.place.operand(text)
        except ValueError as exc:
            raise self.fail(str(exc), key) from None
        if not output and not (operand.settable and operand.is_bit):
            raise self.fail(f"{key} = '{text}': a model drives input or flag bits (I a.b, "
                            "F y.b)", key)
        return operand

    def number(self, key: str, default: float | None = None, *, low: float = 0.0,
               high: float = MAX_MS, above: bool = False) -> float:
        if key not in self.data:
            if default is None:
                raise self.fail(f"{key} is missing", None)
            return default
        return self._number(self.data[key], key, low, high, above)

    def _number(self, value: object, key: str, low: float, high: float, above: bool,
                label: str = "") -> float:
        """``value`` if it is a number in range, else a problem at ``key`` (``label``
        names it in the message, where it is a key of a table inside ``key``)."""
        ok = not isinstance(value, bool) and isinstance(value, int | float)
        number = float(value) if ok and abs(value) <= 1e300 else math.nan  # type: ignore[arg-type]
        if not (low < number <= high if above else low <= number <= high):
            if isinstance(value, str) and key.endswith("_ms"):
                raise self.fail(f"{key} is a number of milliseconds; for a time with a unit "
                                f"write {key[:-3]} = \"{value[:20]}\"", key)
            raise self.fail(f"{label or key} is a number {'above' if above else 'from'} {low:g} "
                            f"{'up ' if above else ''}to {high:g}, not {value!r}"[:120], key)
        return number

    def tables(self, key: str) -> list[Mapping[str, object]]:
        value = self.data.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            raise self.fail(f"{key} is a list of tables: [ {{ input = \"I 1.3\", ... }} ]", key)
        if len(value) > MAX_SENSORS:
            raise self.fail(f"{key}: at most {MAX_SENSORS}, not {len(value)}", key)
        return value

    def values(self, key: str) -> dict[Operand, int]:
        table = self.data.get(key, {})
        if not isinstance(table, dict):
            raise self.fail(f"'{key}' is a table of inputs: {{ \"I 1.0\" = 1 }}", key)
        found = {}
        for text, value in table.items():
            if not isinstance(text, str):  # a table given in Python: any key at all
                raise self.fail(f"'{key}' is a table of inputs: {{ \"I 1.0\" = 1 }}, not a "
                                f"key {text!r}"[:120], key)
            operand = self._operand(text, key, output=True)
            if not operand.settable:
                raise self.fail(f"'{text}' cannot be set by a rule: only inputs (I, IB) and "
                                "flags (F, FY)", key)
            if isinstance(value, bool) or not isinstance(value, int):
                raise self.fail(f"'{text}': expected a whole number, got {value!r}", key)
            try:
                found[operand] = check_value(value, operand, text)
            except ValueError as exc:
                raise self.fail(str(exc), key) from None
        return found


def read_model(data: Mapping[str, object], name: str, place: Place) -> Model | None:
    """The model a ``[[plant]]`` table describes, or None after reporting its problems
    to ``place``; ``name`` names its lanes when the table has no ``name``."""
    kind = data.get("type")
    if not isinstance(kind, str) or kind not in _KEYS:
        from asictl.readers.suggest import did_you_mean

        hint = did_you_mean(kind, list(TYPES)) if isinstance(kind, str) else ""
        place.problem(f"a plant model has a type: {', '.join(TYPES)}"
                      + (f"; not '{kind}'{hint}" if isinstance(kind, str) else ""),
                      "type" if "type" in data else None)
        return None
    keys = _KEYS[kind]
    timed, written = _times(data, keys, place)
    if timed is None:
        return None
    data = timed
    unknown = sorted(set(data) - set(keys) - {"type", "name"})
    if unknown:
        from asictl.readers.suggest import did_you_mean

        for key in unknown:
            place.problem(f"unknown key '{key}' in a {kind}{did_you_mean(key, list(keys))} "
                          f"(known: {', '.join(['name', 'type', *keys])})", key)
        return None
    missing = [key for key, required in keys.items() if required and key not in data]
    if missing:
        place.problem(f"a {kind} needs {', '.join(missing)}", None)
        return None
    label = data.get("name", name)
    if not isinstance(label, str) or not label.strip() or len(label) > 40:
        place.problem("name is a text of 1 to 40 characters", "name")
        return None
    try:
        return _READERS[kind](_Table(data, place, written), label.strip())
    except _Bad:
        return None


def _times(data: Mapping[str, object], keys: Mapping[str, bool], place: Place
           ) -> tuple[Mapping[str, object] | None, dict[str, str]]:
    """``data`` with each time written by its unit-bearing name (``stroke = "2s"``: a
    text with its unit or a number of milliseconds, docs/simulation.md, Durations) as
    its ``_ms`` key in milliseconds, and which keys were so written; None after a
    problem."""
    found = dict(data)
    written: dict[str, str] = {}
    for key in (k for k in keys if k.endswith("_ms")):
        name = key[:-3]
        if name not in data:
            continue
        if key in data:
            place.problem(f"{key} or {name}, not both", name)
            return None, written
        value = found.pop(name)
        try:
            found[key] = ([duration_ms(v, what="each time", limit_ms=MAX_MS)
                           for v in value] if isinstance(value, list)
                          else duration_ms(value, what="the time", limit_ms=MAX_MS))
        except UnitError as exc:
            place.problem(f"{name}: {exc}", name)
            return None, written
        written[key] = name
    return found, written


def _cylinder(t: _Table, name: str) -> Model:
    extend = t.operand("extend", output=True)
    assert extend is not None
    extended, retracted = t.operand("extended", output=False), t.operand("retracted",
                                                                            output=False)
    if extended is None and retracted is None:
        raise t.fail("a cylinder has an end switch: extended, retracted or both", None)
    return Cylinder(name, extend, t.number("stroke_ms", above=True),
                    retract=t.operand("retract", output=True), extended=extended,
                    retracted=retracted)


def _conveyor(t: _Table, name: str) -> Model:
    motor = t.operand("motor", output=True)
    assert motor is not None
    length = t.number("length_mm", above=True, high=1e6)
    speed = t.number("speed_mm_s", above=True, high=1e6)
    times = t.data.get("parts_at_ms", [])
    if not isinstance(times, list) or len(times) > MAX_PARTS:
        raise t.fail(f"parts_at_ms is a list of times in milliseconds (at most {MAX_PARTS})",
                     "parts_at_ms")
    arrivals = [t._number(v, "parts_at_ms", 0.0, MAX_MS, False, "each time") for v in times]
    barriers = []
    for table in t.tables("barriers"):
        extra = sorted(set(table) - {"input", "at_mm"})
        if extra or "input" not in table or "at_mm" not in table:
            raise t.fail("a barrier is { input = \"I 1.3\", at_mm = 800 }", "barriers")
        barrier = _Table(table, t.place)
        found = barrier.operand("input", output=False)
        assert found is not None
        barriers.append(Barrier(found, barrier._number(table["at_mm"], "barriers", 0.0, length,
                                                       False, "at_mm")))
    return Conveyor(name, motor, length, speed, parts_at_ms=arrivals,
                    part_on=t.operand("part_on", output=True), barriers=barriers,
                    part_mm=t.number("part_mm", 50.0, above=True, high=1e6))


def _tank(t: _Table, name: str) -> Model:
    capacity = t.number("capacity", 100.0, above=True, high=1e9)
    switches = []
    for table in t.tables("switches"):
        if sorted(table) != ["at", "input"]:
            raise t.fail("a level switch is { input = \"I 1.2\", at = 80 }", "switches")
        switch = _Table(table, t.place)
        found = switch.operand("input", output=False)
        assert found is not None
        switches.append(Switch(found, switch._number(table["at"], "switches", 0.0, capacity,
                                                     above=True, label="at")))
    fill, drain = t.operand("fill", output=True), t.operand("drain", output=True)
    if fill is None and drain is None:
        raise t.fail("a tank has a fill or a drain output (or both)", None)
    return Tank(name, fill=fill, fill_rate=t.number("fill_rate", 0.0, high=1e9), drain=drain,
                drain_rate=t.number("drain_rate", 0.0, high=1e9),
                level=t.number("level", 0.0, high=capacity), capacity=capacity,
                switches=switches)


def _motor(t: _Table, name: str) -> Model:
    contactor = t.operand("contactor", output=True)
    assert contactor is not None
    running, overload = t.operand("running", output=False), t.operand("overload", output=False)
    trip = t.number("trip_at_ms") if "trip_at_ms" in t.data else None
    if trip is not None and overload is None and running is None:
        raise t.fail("trip_at_ms needs an overload or running input to show the trip",
                     "trip_at_ms")
    return Motor(name, contactor, running=running, start_ms=t.number("start_ms", 0.0),
                 overload=overload, trip_at_ms=trip)


def _rule(t: _Table, name: str) -> Model:
    text = t.data["when"]
    if not isinstance(text, str):
        raise t.fail("when is a condition such as \"Q 2.0 and not I 1.2\"", "when")
    try:
        when = t.place.condition(text)
    except ConditionError as exc:
        t.place.condition_problem(exc, "when")
        raise _Bad() from None
    values = t.values("set")
    if not values:
        raise t.fail("a rule sets at least one input: set = { \"I 1.0\" = 1 }", "set")
    return Rule(name, when, values, after_ms=t.number("after_ms", 0.0),
                otherwise=t.values("else"))


_READERS: dict[str, Callable[[_Table, str], Model]] = {
    "cylinder": _cylinder, "conveyor": _conveyor, "tank": _tank, "motor": _motor, "rule": _rule,
}
