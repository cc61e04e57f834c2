"""Counterexamples far behind timers and counters, found by running the program on input
sequences of few changes (``prove/falsify.py``): real (the scenario fails in the
simulator at its last step), quiet (only the inputs that must change, bit by bit), never
told of a property that holds, and bounded by ``--depth`` and ``--timeout``."""

from __future__ import annotations

import dataclasses
import shutil
import tempfile
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from replay import assert_replays
from test_soundness import EXAMPLES, PHASES_US, _first_bad, programs, properties

from asictl.cli import main
from asictl.prove.counterexample import expectations, scenario_text
from asictl.prove.engine import Machine, Outcome, Verdict
from asictl.prove.falsify import Goal, falsify, first_failure
from asictl.prove.session import load, setup_of
from asictl.prove.session import prove as prove_file

pytest.importorskip("z3")

DEMOS = Path(__file__).resolve().parents[2] / "demos"
HOUR_ENDS = '[[property]]\nname = "the hour never ends"\nnever = "Q 2.1"\n'


def _hour(tmp_path: Path, cycle_ms: int) -> Path:
    shutil.copy(DEMOS / "1h_timer.asi", tmp_path / "h.asi")
    (tmp_path / "h.symbols.toml").write_text('Start = "I 1.0"\nDone = "Q 2.1"\n')
    props = tmp_path / "h.props.toml"
    props.write_text(f"[master]\ncycle_ms = {cycle_ms}\n{HOUR_ENDS}")
    return props


def _steps(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.startswith(("set", "expect"))]


@pytest.mark.parametrize(("cycle_ms", "cycles"), [(1000, 3_601), (10, 360_001)])
def test_the_end_of_the_hour_is_found_in_seconds_and_replays(tmp_path: Path, cycle_ms: int,
                                                             cycles: int):
    props = _hour(tmp_path, cycle_ms)
    began = time.monotonic()
    report = prove_file(props, timeout_s=60.0)
    (outcome,) = report.outcomes
    assert outcome.verdict is Verdict.REFUTED, outcome.note
    assert time.monotonic() - began < 30  # at the limit it would be "unknown" after 60 s
    # a hundred runs of 36 s, the first started by the first cycle
    assert outcome.trace is not None and len(outcome.trace) == cycles
    assert "found by running the program" in outcome.note
    assert "not necessarily the shortest" in outcome.note
    scenario = report.written["the hour never ends"]
    assert_replays(tmp_path / "h.asi", scenario, Verdict.REFUTED)
    text = scenario.read_text()
    # one change, one bit, named as every counterexample names it
    assert _steps(text) == ['set = { "I 1.0" = 1 }', 'expect = { "Q 2.1" = 0 }']
    assert "# names: I 1.0 (Start), Q 2.1 (Done)" in text
    assert "not necessarily the shortest" in text


def test_a_witness_and_a_response_behind_the_hour(tmp_path: Path):
    """The end of the hour reached (the witness passes) and a response that waits
    longer than half an hour (its counterexample fails at the cycle the wait ends)."""
    props = _hour(tmp_path, 1000)
    props.write_text('[master]\ncycle_ms = 1000\n[[property]]\nname = "the end"\n'
                     'reachable = "Q 2.1"\n[[property]]\nname = "half an hour"\n'
                     'when = "Q 2.0"\nthen = "Q 2.1 or not Q 2.0"\nwithin = "30min"\n')
    report = prove_file(props, timeout_s=60.0)
    found = {o.prop.name: o for o in report.outcomes}
    assert found["the end"].verdict is Verdict.REACHED
    assert found["half an hour"].verdict is Verdict.REFUTED
    # the answer is waited for from the first cycle: 1,800 cycles after it, too late
    assert len(found["half an hour"].trace or ()) == 1_801
    for name, outcome in found.items():
        assert "found by running the program" in outcome.note
        assert_replays(tmp_path / "h.asi", report.written[name], outcome.verdict)


def test_a_depth_given_bounds_the_runs(tmp_path: Path):
    """--depth 250 (cycles of 1 s) cannot reach the end of the hour: no counterexample,
    where without it one is found."""
    props = _hour(tmp_path, 1000)
    result = main(["prove", str(props), "--depth", "250", "--timeout", "2s"],
                  standalone_mode=False)
    assert result == 1
    assert not list(tmp_path.glob("*.scenario.toml"))


RISE = """[SETUP]
1: iiii, 0
2: oooo, 0

[PROGRAM]
        A   I 1.0           ; remember the start
        S   F 0.0
***
        L   KT 5000         ; 5 s after I 1.1 came on
        A   I 1.1
        AN  I2 1.1
        S   T 1
***
        AN  I 1.1
        R   T 1
***
        A   F 0.0
        A   I 1.1
        AN  T 1
        =   Q 2.0
***
        A   I 1.3           ; out of the property's cone
        =   Q 2.3
"""


def _machine(props: Path, accept: list[Outcome]) -> Machine:
    """The machine of ``prove``, its concrete runs' candidates taken as they come (and
    kept in ``accept``), so that the test, not the prover's replay, judges them."""
    read, _, built = load(props, None, ())
    setup, _ = setup_of(read, built)
    assert built.program is not None

    def replay(outcome: Outcome) -> bool:
        accept.append(outcome)
        return True

    return Machine(built.program, setup, read.assume, read.properties, replay=replay)


def _written(props: Path, machine: Machine, outcome: Outcome) -> Path:
    read, program, _ = load(props, None, ())
    target = props.parent / "found.scenario.toml"
    target.write_text(scenario_text(read, program, target, outcome.prop, outcome,
                                    machine.cycle.host_masks, machine.setup.cycle_us / 1000,
                                    expectations(outcome.prop, outcome, outcome.values)))
    return target


def test_two_changes_are_found_and_only_the_cone_is_set(tmp_path: Path):
    (tmp_path / "p.asi").write_text(RISE)
    props = tmp_path / "p.props.toml"
    props.write_text('[master]\ncycle_ms = 10\n[[property]]\nname = "on"\nnever = "Q 2.0"\n')
    machine = _machine(props, [])
    start = time.monotonic()
    outcome = machine.falsify(machine.properties[0], searched=1, depth=20, horizon=None,
                              start=start, deadline=start + 30)
    assert outcome is not None and outcome.trace is not None
    # I 1.0 and I 1.1 from the first cycle, the timer's 500 ticks, and the cycle that
    # sees it run out
    assert len(outcome.trace) == 501
    text = _written(props, machine, outcome).read_text()
    assert _steps(text) == ['set = { "I 1.0" = 1, "I 1.1" = 1 }', 'expect = { "Q 2.0" = 0 }']
    assert_replays(tmp_path / "p.asi", tmp_path / "found.scenario.toml", Verdict.REFUTED)


@pytest.mark.parametrize("cycle_us", [3_000, 7_000, 10_000, 25_000, 1_000_000])
@pytest.mark.parametrize("phase_us", [1, 4_000, 10_000])
def test_idle_stretches_run_in_one_go_end_where_cycle_by_cycle_runs_do(
        tmp_path: Path, cycle_us: int, phase_us: int):
    """The hour of the demo shortened to 5 runs of 0.5 s: the runs that jump over idle
    stretches find the failure after as many cycles as the runs that take every cycle,
    at cycles shorter and longer than the 10 ms tick and on any phase of it."""
    (tmp_path / "h.asi").write_text((DEMOS / "1h_timer.asi").read_text().replace(
        "KC 100", "KC 5").replace("KT 36000", "KT 500"))
    props = tmp_path / "h.props.toml"
    props.write_text(f"[master]\ncycle_ms = {cycle_us / 1000:g}\n{HOUR_ENDS}")
    read, _, built = load(props, None, ())
    assert built.program is not None

    def cycles(jumps: bool) -> int:
        goal = Goal(read.properties[0], [], [("in", 1, 0), ("in", 1, 1)], (1, 2), {},
                    cycle_us, phase_us, 0, 6_000_000 // cycle_us + 20, jumps)
        found = falsify(built.program, goal, time.monotonic() + 60)
        assert found is not None
        return len(found.inputs)

    assert cycles(True) == cycles(False)


def test_the_runs_end_at_their_time(tmp_path: Path):
    props = _hour(tmp_path, 10)
    machine = _machine(props, [])
    start = time.monotonic()
    assert machine.falsify(machine.properties[0], searched=1, depth=20, horizon=None,
                           start=start, deadline=start) is None
    assert time.monotonic() - start < 2


def test_a_property_that_holds_is_not_refuted(tmp_path: Path):
    shutil.copy(DEMOS / "1h_timer.asi", tmp_path / "h.asi")
    shutil.copy(DEMOS / "1h_timer.props.toml", tmp_path / "h.props.toml")
    found: list[Outcome] = []
    machine = _machine(tmp_path / "h.props.toml", found)
    for prop in machine.properties:
        start = time.monotonic()
        assert machine.falsify(prop, searched=1, depth=20, horizon=None, start=start,
                               deadline=start + 1) is None
    assert not found


def _check_generated(program: str, props_text: str, tmp_path: Path) -> None:
    (tmp_path / "p.asi").write_text(program)
    props = tmp_path / "p.props.toml"
    props.write_text(props_text)
    report = prove_file(props, timeout_s=120.0, depth=5)
    found: list[Outcome] = []
    machine = _machine(props, found)
    cycle_us = machine.setup.cycle_us
    assert machine.program is not None
    for decided in report.outcomes:
        start = time.monotonic()
        outcome = machine.falsify(decided.prop, searched=0, depth=5, horizon=40, start=start,
                                  deadline=start + 20)
        where = f"{program}\n{props_text}\n{decided.verdict}"
        if outcome is None:
            continue
        assert decided.verdict not in (Verdict.PROVED, Verdict.UNREACHABLE), where
        assert outcome.trace is not None
        cycles = len(outcome.trace)
        # a real failure, no shorter than the shortest, on the phase it names
        phase = outcome.phase_us or machine.setup.phase_us or PHASES_US[0]
        first = _first_bad(machine.program, decided.prop, cycles, cycle_us, phase)
        assert first is not None and first <= cycles, where
        assert_replays(tmp_path / "p.asi", _written(props, machine, outcome),
                       outcome.verdict)


#: the generated programs with timers of 0.2 to 0.6 s (up to 600 cycles at 1 to 25 ms
#: cycles): long idle stretches, run in one go or cycle by cycle
long_timers = programs.map(lambda text: text.replace("KT 10\n", "KT 200\n").replace(
    "KT 20\n", "KT 450\n").replace("KT 30\n", "KT 600\n"))
#: a timer of its own, started by a rising edge of I 1.1, and a flag that the first
#: cycle after it runs out with I 1.1 on sets: a property on it fails there
EXPIRES = """        L   KT 370
        A   I 1.1
        AN  I2 1.1
        S   T 2
***
        A   I 1.1
        AN  T 2
        S   F 9.0
***
"""
#: up to three changes of the three inputs, at cycles within the horizon
HORIZON = 400
schedules = st.lists(st.tuples(st.integers(0, HORIZON - 1), st.integers(0, 2)), max_size=3)


@settings(max_examples=4 * EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(long_timers, properties(), schedules)
def test_generated_runs_jump_over_idle_stretches_to_where_every_cycle_goes(
        program: str, props_text: str, schedule: list[tuple[int, int]]) -> None:
    """On one input sequence, the runs that jump over idle stretches fail (or not)
    after as many cycles as the runs that take every cycle."""
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "p.asi").write_text(program + EXPIRES)
        props = Path(folder) / "p.props.toml"
        props.write_text(props_text + '[[property]]\nname = "expired"\nnever = "F 9.0"\n')
        machine = _machine(props, [])
        assert machine.program is not None
        changes = [(cycle, ("in", 1, bit)) for cycle, bit in schedule]
        for prop in machine.properties:
            machine.current, machine.scope = prop, machine.cone(prop)
            goal = dataclasses.replace(machine.goal(prop, HORIZON),
                                       bits=[("in", 1, b) for b in range(3)])
            assert goal.jumps
            jumped, stepped = (first_failure(machine.program, dataclasses.replace(
                goal, jumps=jumps), changes) for jumps in (True, False))
            assert jumped == stepped, f"{program}\n{props_text}\n{schedule}"


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(programs, properties())
def test_generated_programs_are_refuted_only_where_they_fail(program: str, props: str) -> None:
    with tempfile.TemporaryDirectory() as folder:
        _check_generated(program, props, Path(folder))


@pytest.mark.slow
@settings(max_examples=25 * EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(programs, properties())
def test_generated_programs_are_refuted_only_where_they_fail_long(program: str,
                                                                 props: str) -> None:
    with tempfile.TemporaryDirectory() as folder:
        _check_generated(program, props, Path(folder))
