"""Hostile plant models, generated with hypothesis: a scenario's ``[[plant]]`` tables with
values of the wrong type, huge and tiny numbers, NaN, deep nesting, NUL and control
characters, unknown keys and conditions that do not read, each run by ``asictl sim`` to
the scenario's end; and plant models written in Python (``asictl.testing``) that set
values of every wrong type and range, read what is no operand, or raise.

``asictl sim`` answers each file with its result (exit 0 or 1) or with an error at the
file's line (exit 2), never an internal error (exit 3) or a hang: hypothesis's deadline
bounds each run. A Python model's bad value is a ``ValueError`` or ``TypeError`` naming
the operand, its own exception reaches the test unchanged (a failing test), and the
``Plc`` runs on after either. Sized for CI; ``-m slow`` runs many more examples."""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from collections.abc import Mapping
from datetime import date
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from asictl.cli import main
from asictl.observe.operands import Operand, parse_operand
from asictl.sim.plant import TYPES, Barrier, Conveyor
from asictl.testing import Plc

#: Slave 1 has the inputs I 1.0 to I 1.3, slave 2 the outputs Q 2.0 to Q 2.3; the
#: scenario turns every output on and off again, so that the models move.
PROGRAM = """[SETUP]
1: iiii, 0
2: oooo, 0

[PROGRAM]
        A   I 1.2
        =   Q 2.0
        =   Q 2.1
        =   Q 2.2
***
        AN  I 1.2
        =   Q 2.3
"""
STEPS = ["[[step]]", "at_ms = 0", 'set = { "I 1.2" = 1 }', "[[step]]", "at_ms = 300",
         'set = { "I 1.2" = 0 }', "[[step]]", "at_ms = 600"]

#: A valid table of each type, the start of every hostile one.
VALID: dict[str, dict[str, object]] = {
    "cylinder": {"extend": "Q 2.0", "retract": "Q 2.3", "extended": "I 1.0",
                 "retracted": "I 1.1", "stroke_ms": 300},
    "conveyor": {"motor": "Q 2.1", "length_mm": 1000, "speed_mm_s": 500,
                 "parts_at_ms": [0, 100], "part_on": "Q 2.2", "part_mm": 50,
                 "barriers": [{"input": "I 1.3", "at_mm": 800}]},
    "tank": {"fill": "Q 2.0", "fill_rate": 10, "drain": "Q 2.1", "drain_rate": 5,
             "level": 10, "capacity": 100, "switches": [{"input": "I 1.3", "at": 50}]},
    "motor": {"contactor": "Q 2.0", "running": "I 1.0", "start_ms": 100, "overload": "I 1.1",
              "trip_at_ms": 500},
    "rule": {"when": "Q 2.0 and not I 1.2", "after_ms": 50, "set": {"I 1.0": 1},
             "else": {"I 1.0": 0}},
}
assert sorted(VALID) == sorted(TYPES)

TEXTS = st.one_of(
    st.text(max_size=30),
    st.sampled_from([
        "", " ", "Q 2.0", "I 1.0", "I 1.3", "F 10.0", "FY 10", "IB 1", "Q 2", "T 0", "CV 0",
        "I 31.3", "Q 99.9", "I 1.0\x00", "\x00", "\x1b[2J", "\u202e", "\ud800", "é" * 50,
        "2s", "25h", "1e999ms", "-1ms", "nan", "inf", "0", "300", "1.5min", "9" * 400,
        "Q 2.0 and", "Q 2.0 or or I 1.0", "not " * 200, "(" * 100 + "Q 2.0" + ")" * 100,
        "Q 2.0 == 99999999999999999999", "RLO", "x" * 200,
    ]),
)
NUMBERS = st.one_of(
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, 1, -1, 2**63 - 1, -(2**63), 1e308, -1e308, 5e-324, 1e-300,
                     86_400_000, 86_400_001, 1e6, 1e9 + 1, 0.0001]),
)
LEAVES = st.one_of(st.booleans(), NUMBERS, TEXTS, st.just(date(2024, 1, 1)))
VALUES = st.recursive(
    LEAVES,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(TEXTS, inner, max_size=4),
    max_leaves=12,
)
KEYS = st.sampled_from(sorted({k for table in VALID.values() for k in table}
                              | {"type", "name", "stroke", "after", "start", "trip_at",
                                 "parts_at"}))


def toml_value(value: object, raw: bool) -> str:
    """``value`` as TOML; ``raw`` leaves control and other characters unescaped in
    strings (which TOML refuses in some places: the reader must say so)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else {math.inf: "inf", -math.inf: "-inf"}.get(
            value, repr(value))
    if isinstance(value, int | date):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=not raw)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v, raw) for v in value) + "]"
    assert isinstance(value, Mapping)
    return "{ " + ", ".join(f"{toml_value(str(k), raw)} = {toml_value(v, raw)}"
                            for k, v in value.items()) + " }"


@st.composite
def plant_tables(draw: st.DrawFn) -> list[dict[str, object]]:
    """One or two ``[[plant]]`` tables, each a valid one with up to 4 keys replaced by
    hostile values, removed or added, and at times a hostile type."""
    tables = []
    for _ in range(draw(st.integers(1, 2))):
        kind = draw(st.sampled_from(sorted(VALID)))
        table: dict[str, object] = {"type": kind, **VALID[kind]}
        for _ in range(draw(st.integers(1, 4))):
            edit = draw(st.sampled_from(["value", "remove", "add", "nest"]))
            key = draw(st.sampled_from(sorted(table)) if edit != "add" and table else KEYS)
            if edit == "remove":
                table.pop(key, None)
            elif edit == "nest":
                depth = draw(st.integers(1, 200))
                table[key] = json.loads("[" * depth + "1" + "]" * depth)
            else:
                table[key] = draw(VALUES)
        tables.append(table)
    return tables


def scenario_text(tables: list[dict[str, object]], raw: bool) -> str:
    """A scenario of the program beside it (drive.asi) with these ``[[plant]]`` tables."""
    lines = ['program = "drive.asi"', "[master]", "cycle_ms = 5"]
    for table in tables:
        lines.append("[[plant]]")
        lines += [f"{toml_value(key, raw)} = {toml_value(value, raw)}"
                  for key, value in table.items()]
    return "\n".join([*lines, *STEPS]) + "\n"


@pytest.fixture(scope="module")
def scenario_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("plants")
    (folder / "drive.asi").write_text(PROGRAM)
    return folder / "hostile.scenario.toml"


def simulated_plainly(path: Path, text: str) -> None:
    """``asictl sim`` on ``text``: a result, or an error at the file's line; never an
    internal error."""
    path.write_text(text, encoding="utf-8", errors="surrogatepass")  # "\ud800" unescaped
    result = CliRunner().invoke(main, ["sim", "--scenario", str(path)])
    assert result.exit_code in (0, 1, 2), (result.exit_code, result.output, text)
    assert "internal error" not in result.output and "Traceback" not in result.output, (
        result.output, text)
    if result.exit_code == 2:
        assert re.search(rf"{re.escape(str(path))}:\d+:(\d+:)? error: ", result.stderr), (
            result.stderr, text)


@pytest.mark.parametrize("kind", sorted(VALID))
def test_the_valid_tables_run(scenario_file, kind):
    """The tables each hostile one starts from are read and run (a hostile file that
    fails, fails for what was done to it)."""
    scenario_file.write_text(scenario_text([{"type": kind, **VALID[kind]}], raw=False))
    result = CliRunner().invoke(main, ["sim", "--scenario", str(scenario_file)])
    assert result.exit_code == 0, result.output
    assert "error" not in result.stderr and "warning" not in result.stderr


@pytest.mark.parametrize(("table", "switch"), [
    ({"type": "conveyor", "motor": "Q 2.1", "length_mm": 1000, "speed_mm_s": 1e-300,
      "parts_at_ms": [0], "barriers": [{"input": "I 1.3", "at_mm": 800}]}, 0),
    ({"type": "tank", "fill": "Q 2.0", "fill_rate": 1e-300, "capacity": 1e9,
      "switches": [{"input": "I 1.3", "at": 1e9}]}, 0),
    ({"type": "tank", "drain": "Q 2.3", "drain_rate": 1e-300, "level": 1e9, "capacity": 1e9,
      "switches": [{"input": "I 1.3", "at": 1}]}, 1),
], ids=["conveyor", "filling tank", "draining tank"])
def test_a_model_that_crawls_never_switches(scenario_file, table, switch):
    """Found by the test below: a speed or rate so small that the time to the next
    switch is an infinite float (no integer of microseconds) was an internal error; such
    a moment is never, and the input stays as it is."""
    scenario_file.write_text(scenario_text([table], raw=False).replace(
        "at_ms = 600", f'at_ms = 600\nexpect = {{ "I 1.3" = {switch} }}'))
    result = CliRunner().invoke(main, ["sim", "--scenario", str(scenario_file)])
    assert result.exit_code == 0, result.output


@settings(max_examples=40, deadline=10_000, suppress_health_check=[HealthCheck.too_slow])
@given(tables=plant_tables(), raw=st.booleans())
def test_a_hostile_plant_table_is_simulated_or_refused_plainly(scenario_file, tables, raw):
    simulated_plainly(scenario_file, scenario_text(tables, raw))


@pytest.mark.slow
@settings(max_examples=2000, deadline=10_000, suppress_health_check=[HealthCheck.too_slow])
@given(tables=plant_tables(), raw=st.booleans())
def test_a_hostile_plant_table_is_simulated_or_refused_plainly_long_run(scenario_file, tables,
                                                                        raw):
    simulated_plainly(scenario_file, scenario_text(tables, raw))


def test_a_full_belt_under_every_barrier_runs_in_seconds(scenario_file):
    """10,000 parts (the most a belt holds) under 32 barriers (the most it has): each
    part's run moved one by one and each edge of each part a moment to evaluate took
    minutes (16 barriers: 39 s, 32: past a minute; hours with more barriers, now
    refused). The deadline is generous for a shared machine; it takes about 3 s."""
    scenario_file.write_text(scenario_text([{
        "type": "conveyor", "motor": "Q 2.1", "length_mm": 1000, "speed_mm_s": 1_000_000,
        "parts_at_ms": [i / 20 for i in range(10_000)],
        "barriers": [{"input": f"F {10 + i // 8}.{i % 8}", "at_mm": i} for i in range(32)],
    }], raw=False))
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2] / "src")}
    result = subprocess.run([sys.executable, "-m", "asictl", "sim", "--scenario",
                             str(scenario_file)], capture_output=True, text=True, env=env,
                            timeout=60)
    assert result.returncode == 0, result.stderr


# ---------------------------------------------------------------- plant models in Python


class Weird:
    """An object no operand holds."""

    def __repr__(self) -> str:
        return "<weird>"


#: Operands a Python model names: (text, the largest value, can a model set it).
OPERANDS = [("I 1.0", 1, True), ("I 1", 15, True), ("F 10.0", 1, True),
            ("FY 10", 255, True), ("Q 2.0", 1, False), ("T 0", 1, False)]
SET_VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-(2**70), 2**70), st.integers(-2, 300),
    st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0.0, 1.0, 15.0, 0.5]),
    TEXTS, st.just(b"\x01"), st.just(1j), st.just([1]), st.just({"I 1.0": 1}),
    st.builds(Weird),
)
BAD_NAMES = st.one_of(TEXTS, st.none(), st.integers(), st.just(b"I 1.0"), st.builds(Weird))


class Boom(Exception):
    """What a model raises of its own."""


#: One thing a model does on its first call: set an operand to a value, read one by a
#: name that may be none, raise, or return a value.
ACTIONS = st.one_of(
    st.tuples(st.just("set"), st.sampled_from(OPERANDS), SET_VALUES),
    st.tuples(st.just("read"), BAD_NAMES),
    st.tuples(st.just("raise"), st.sampled_from([Boom, ZeroDivisionError, KeyError,
                                                 RecursionError, MemoryError])),
    st.tuples(st.just("return"), SET_VALUES),
)


def settable_as(value: object, largest: int) -> int | None:
    """What a set of ``value`` stores, by the documented rule (a bool or a whole number,
    a float only when whole, within the operand's range), None if it is refused."""
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if not isinstance(value, int) or not 0 <= value <= largest:
        return None
    return int(value)


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("models") / "drive.asi"
    path.write_text(PROGRAM)
    return path


def model_answers_plainly(drive: Path, actions: list[tuple[object, ...]]) -> None:
    """Runs a model doing ``actions`` on its first program cycle: the first one that is
    wrong is an exception that says so, a model's own exception reaches the test
    unchanged; either way the ``Plc`` runs on, and the last value set holds."""
    plc = Plc.load(drive, cycle_ms=5)
    calls = []
    refused: list[tuple[object, str]] = []

    def model(elapsed: float) -> object:
        calls.append(elapsed)
        if len(calls) > 1:
            return None
        for action in actions:
            if action[0] == "set":
                (text, _, _), value = action[1:]
                plc[text] = value
            elif action[0] == "read":  # a name may be an operand's or not
                try:
                    plc[action[1]]
                except (ValueError, TypeError) as exc:
                    refused.append((action[1], str(exc)))
            elif action[0] == "raise":
                raise action[1]("raised by the model")
            else:
                return action[1]
        return None

    plc.on_cycle(model)
    stored: list[tuple[str, int]] = []
    wanted: type[BaseException] | tuple[type[BaseException], ...] | None = None
    for action in actions:
        if action[0] == "set":
            (text, largest, settable), value = action[1:]
            ok = settable_as(value, largest)
            if settable and ok is not None:
                stored.append((text, ok))
                continue
            wanted, words = (ValueError, TypeError), [text]
        elif action[0] == "read":
            continue
        elif action[0] == "raise":
            wanted, words = action[1], ["raised by the model"]
        elif action[1] is not None:
            wanted, words = TypeError, ["returns nothing"]
        break
    if wanted is None:
        plc.run("20ms")
    else:
        with pytest.raises(wanted) as caught:
            plc.run("20ms")
        assert all(word in str(caught.value) for word in words), (caught.value, words)
    assert calls[0] == 0.0
    for name, message in refused:  # what is wrong, about that name
        assert message.strip() and (isinstance(name, str) or "an operand is a text" in message)
    plc.run("20ms")  # on after the failure: the model's next calls do nothing
    assert len(calls) > 2
    if stored:  # the last set holds (the ones before it may share its bits)
        plc.expect(*stored[-1])


#: Python's own values, which no TOML file holds: None, tuples, sets, bytes, complex
#: numbers, keys that are no text, objects.
PY_VALUES = st.recursive(
    st.one_of(LEAVES, st.none(), st.just(b"Q 2.0"), st.just(1j), st.builds(Weird)),
    lambda inner: (st.lists(inner, max_size=3) | st.lists(inner, max_size=3).map(tuple)
                   | st.dictionaries(st.one_of(TEXTS, st.integers(), st.none()), inner,
                                     max_size=3)),
    max_leaves=8,
)


@st.composite
def python_tables(draw: st.DrawFn) -> tuple[str, dict[str, object]]:
    """A valid table of a type with up to 3 keys given a Python value, or removed."""
    kind = draw(st.sampled_from(sorted(VALID)))
    table = dict(VALID[kind])
    for _ in range(draw(st.integers(1, 3))):
        key = draw(KEYS)
        if key == "type" or (draw(st.booleans()) and table.pop(key, None) is not None):
            continue
        table["else_" if key == "else" else key] = draw(PY_VALUES)
    return kind, table


def add_plant_answers_plainly(drive: Path, kind: str, table: dict[str, object]) -> None:
    """``add_plant`` makes the model or says what is wrong (``ValueError``); a model it
    makes runs."""
    plc = Plc.load(drive, cycle_ms=5)
    try:
        model = plc.add_plant(kind, **table)
    except ValueError as exc:
        assert str(exc), table
        return
    assert model.kind == kind
    start = plc.operand("I 1.2")
    for value in (1, 0):
        if start not in model.driven():
            plc.set("I 1.2", value)
        plc.run("300ms")
    assert plc.time_ms == 600


@settings(max_examples=40, deadline=5000, suppress_health_check=[HealthCheck.too_slow])
@given(made=python_tables())
@example(made=("rule", {**VALID["rule"], "set": {None: 1}}))  # a key that is no text
def test_a_hostile_table_given_in_python_is_refused_plainly(drive, made):
    add_plant_answers_plainly(drive, *made)


@pytest.mark.slow
@settings(max_examples=2000, deadline=5000, suppress_health_check=[HealthCheck.too_slow])
@given(made=python_tables())
def test_a_hostile_table_given_in_python_is_refused_plainly_long_run(drive, made):
    add_plant_answers_plainly(drive, *made)


@settings(max_examples=60, deadline=5000, suppress_health_check=[HealthCheck.too_slow])
@given(actions=st.lists(ACTIONS, min_size=1, max_size=4))
def test_a_hostile_python_model_is_told_plainly(drive, actions):
    model_answers_plainly(drive, actions)


@pytest.mark.slow
@settings(max_examples=2000, deadline=5000, suppress_health_check=[HealthCheck.too_slow])
@given(actions=st.lists(ACTIONS, min_size=1, max_size=4))
def test_a_hostile_python_model_is_told_plainly_long_run(drive, actions):
    model_answers_plainly(drive, actions)


# ---------------------------------------------------------------- the belt, part by part


class NaiveBelt:
    """A belt moved part by part, each barrier asked of each part: the reference the
    conveyor's searches must agree with."""

    def __init__(self, belt: Conveyor) -> None:
        self.edges = belt._edges
        self.length = belt.length
        self.parts: list[int] = []

    def advance(self, dt: int, running: bool) -> None:
        self.parts = [run + dt for run in self.parts] if running else self.parts

    def put(self) -> None:
        self.parts.append(0)

    def leave(self) -> None:
        self.parts = [run for run in self.parts if run < self.length]

    def inputs(self) -> list[int]:
        return [int(any(start <= run < end for run in self.parts)) for start, end in self.edges]


class Outputs:
    """The motor and the part sensor as a schedule gives them; the barriers as written."""

    def __init__(self, motor: Operand, part_on: Operand) -> None:
        self.motor, self.part_on = motor, part_on
        self.values = {str(motor): 0, str(part_on): 0}
        self.written: dict[str, int] = {}

    def read(self, operand: Operand) -> int:
        return self.values.get(str(operand), 0)

    def write(self, operand: Operand, value: int) -> None:
        self.written[str(operand)] = value


@settings(max_examples=60, deadline=5000, suppress_health_check=[HealthCheck.too_slow])
@given(at_mm=st.lists(st.integers(0, 1000), min_size=1, max_size=6),
       part_mm=st.integers(1, 120), speed=st.sampled_from([50, 100, 333, 1000]),
       events=st.lists(st.tuples(st.integers(1, 400_000), st.sampled_from(["motor", "part"])),
                       max_size=40))
def test_the_belt_agrees_with_moving_each_part(at_mm, part_mm, speed, events):
    """The conveyor's barriers, evaluated at its own next changes and at the moments the
    motor or the part sensor changes, hold what moving every part and asking every
    barrier of every part gives; between two of its next changes no barrier changes
    (the reference is asked at every edge of every part), and at each something does."""
    motor, part_on = parse_operand("Q 2.1"), parse_operand("Q 2.2")
    inputs = [parse_operand(f"F 10.{i}") for i in range(len(at_mm))]
    belt = Conveyor("belt", motor, 1000, speed, part_on=part_on, part_mm=part_mm,
                    barriers=[Barrier(i, at) for i, at in zip(inputs, at_mm, strict=True)])
    naive = NaiveBelt(belt)
    io = Outputs(motor, part_on)
    pending = sorted(events)
    now = 0
    belt.update(0, io)
    while pending or belt.next_change() is not None:
        change = belt.next_change()
        if pending and (change is None or pending[0][0] < change):
            at, what = pending.pop(0)
        else:
            assert change is not None
            at, what = change, ""
        # every moment the reference would change in between: nothing changes there
        edges = sorted({start - run for start, _ in naive.edges for run in naive.parts}
                       | {end - run for _, end in naive.edges for run in naive.parts})
        for step in (e for e in edges if 0 < e < at - now) if io.values[str(motor)] else ():
            between = NaiveBelt(belt)
            between.parts = [run + step for run in naive.parts]
            assert between.inputs() == naive.inputs(), (now, step, at)
        before = (naive.inputs(), len(naive.parts))
        naive.advance(at - now, bool(io.values[str(motor)]))
        naive.leave()
        belt.update(at / 1000, io)
        now = at
        if not what:  # the belt's own next change: a barrier changed, or a part left
            assert (naive.inputs(), len(naive.parts)) != before, now
        if what:
            key = str(motor if what == "motor" else part_on)
            io.values[key] ^= 1
            if what == "part" and io.values[key]:
                naive.put()
            belt.update(at / 1000, io)
        assert [io.written.get(str(i), 0) for i in inputs] == naive.inputs(), now
        assert belt.parts == naive.parts  # the one furthest along first
