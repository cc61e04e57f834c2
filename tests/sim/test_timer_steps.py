"""The master's step over the ticks of timers whose remaining time the program never reads.

An idle master with only such timers running counts their ticks down in one step, to
the tick before the first runs out (board/board.py, docs/master.md "Speed"). These tests
hold it to the reference interpreter (``il.oracle``, which shares no code with the
compiler, the board or the engine) driven by the timing contract and the master's 10 ms
clock: generated programs start, restart, stop, rewrite and read timers while their
inputs change, and every output, timer, counter and flag they use is checked at every
step. A step too many or too few, or a rewrite the board missed, changes what is
expected. Other tests show that the step is taken, and that it is not where a timer's
time is read or watched, or where the image does not say which timers are read.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from asictl.build import Build, build
from asictl.il.oracle import Interpreter
from asictl.image.eeprom import ProgramImage
from asictl.platform.master import TICK_US
from asictl.sim.engine import Simulation, variables_of
from asictl.sim.scenario import read_scenario
from asictl.source import from_string

EXAMPLES = int(os.environ.get("ASICTL_TIMER_EXAMPLES", "10"))
SETUP = "[SETUP]\n1: iiii, 0\n2: oooo, 0\n"
TIMES_MS = (10, 20, 50, 130, 500, 990, 2550, 2560, 2570, 3000)
TIMERS = (1, 2, 3)


@st.composite
def _block(draw: st.DrawFn, index: int) -> tuple[list[str], set[str]]:
    """Lines of one piece of a program, and the operands it makes worth watching."""
    n, b, q = draw(st.sampled_from(TIMERS)), draw(st.integers(0, 3)), draw(st.integers(0, 3))
    kt = draw(st.sampled_from(TIMES_MS))
    timer = {f"TV {n}", f"T {n}"}
    match draw(st.sampled_from(["start", "hold", "stop", "show", "count", "read", "write"])):
        case "start":  # once it has run out (the timer example of the manual)
            return [f"A I 1.{b}", f"AN T {n}", f"L KT {kt}", f"S T {n}"], timer
        case "hold":  # restarted every cycle while the input is on (an off-delay)
            return [f"L KT {kt}", f"A I 1.{b}", f"S T {n}"], timer
        case "stop":
            return [f"A I 1.{b}", f"R T {n}"], timer
        case "show":
            return [f"A T {n}", f"{draw(st.sampled_from(['A', 'AN', 'O']))} I 1.{b}",
                    f"= Q 2.{q}"], {*timer, "QB 2"}
        case "count":  # cycles counted while it is not running: cycle-exact
            return [f"AN T {n}", f"CU C {index % 2}"], {*timer, f"CV {index % 2}"}
        case "read":  # the remaining time read: this timer ticks one by one
            return [f"L T {n}", f"T FW {10 + 2 * (index % 2)}"], \
                {*timer, f"FY {10 + 2 * (index % 2)}", f"FY {11 + 2 * (index % 2)}"}
        case _:  # rewritten with a constant while the input is off: held, never running out
            value = draw(st.integers(1, 300))
            return [f"A I 1.{b}", f"JC = w{index}", f"L KW {value}", f"T T {n}",
                    f"w{index}: A I 1.{b}", f"= F 30.{index % 8}"], timer


@st.composite
def timer_programs(draw: st.DrawFn) -> tuple[str, list[str]]:
    lines: list[str] = []
    watched: set[str] = set()
    for index in range(draw(st.integers(1, 6))):
        block, names = draw(_block(index))
        lines += [*block, "***"]
        watched |= names
    return SETUP + "[PROGRAM]\n" + "".join(f"    {line}\n" for line in lines), sorted(watched)


@dataclass(frozen=True)
class Step:
    at_us: int
    inputs: int | None  # the four input bits of slave 1
    expect: bool


@st.composite
def step_lists(draw: st.DrawFn) -> list[Step]:
    times = st.one_of(st.integers(0, 9000).map(lambda ms: ms * 1000),
                      st.integers(0, 9_000_000))
    steps = [Step(draw(times), draw(st.none() | st.integers(0, 15)), draw(st.booleans()))
             for _ in range(draw(st.integers(1, 10)))]
    return [*steps, Step(9_500_000, None, True)]


def _read(interp: Interpreter, name: str) -> int:
    kind, number = name.split()
    n, state = int(number), interp.state
    match kind:
        case "TV":
            return 10 * state.timers.get(n, 0)
        case "T":
            return int(state.timers.get(n, 0) > 0)
        case "CV":
            return state.counters.get(n, 0)
        case "QB":
            return state.outputs[n >> 1]
        case _:
            return state.flags[n]


def reference(text: str, period_us: int, phase_us: int, steps: list[Step],
              watched: list[str]) -> list[dict[str, int]]:
    """Each step's watched values under the contract: cycle k at k * period, the 10 ms
    ticks at phase + j * 10 ms (a tick before a cycle at the same time), a check at T
    after the cycles and ticks before T, a set at T for the cycles from T on."""
    built = build(from_string("prog.asi", text))
    assert built.program is not None
    interp = Interpreter(built.program)
    inputs, cycle, tick = 0, 0, phase_us
    values: list[dict[str, int]] = [{} for _ in steps]
    for at in sorted({s.at_us for s in steps}):
        while min(cycle * period_us, tick) < at:
            if tick <= cycle * period_us:
                interp.tick()
                tick += TICK_US
            else:
                image = bytearray(16)
                image[0] = inputs << 4  # slave 1: the high nibble of byte 0
                interp.cycle(bytes(image))
                cycle += 1
        group = [i for i, s in enumerate(steps) if s.at_us == at]
        for i in group:
            if steps[i].inputs is not None:
                inputs = steps[i].inputs
        for i in group:
            if steps[i].expect:
                values[i] = {name: _read(interp, name) for name in watched}
    return values


def scenario_text(period_us: int, steps: list[Step], values: list[dict[str, int]]) -> str:
    out = [f"[master]\ncycle_ms = {period_us / 1000}\n"]
    for step, expected in zip(steps, values, strict=True):
        out.append(f"[[step]]\nat_ms = {step.at_us / 1000}\n")
        if step.inputs is not None:
            out.append("set = { " + ", ".join(f'"I 1.{b}" = {step.inputs >> b & 1}'
                                              for b in range(4)) + " }\n")
        if expected:
            out.append("expect = { " + ", ".join(f'"{k}" = {v}' for k, v in expected.items())
                       + " }\n")
    return "".join(out)


def _simulation(built: Build, text: str) -> Simulation:
    assert built.image is not None
    return Simulation(built, read_scenario(from_string("s.toml", text),
                                           variables_of(built.image.pmap)))


def _phase(simulation: Simulation) -> int:
    """When the master's first tick after time 0 comes, in microseconds after time 0."""
    board = simulation.board
    return board.next_tick_us - board.now_us + round(simulation.now_ms() * 1000)


@settings(max_examples=EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(timer_programs(), st.sampled_from([1000, 2500, 5000, 7000, 10_000]), step_lists())
def test_generated_timer_programs_agree_with_the_reference_interpreter(program, period, steps):
    timer_programs_agree(program, period, steps)


@pytest.mark.slow
@settings(max_examples=10 * EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(timer_programs(), st.sampled_from([1000, 2500, 5000, 7000, 10_000]), step_lists())
def test_generated_timer_programs_agree_with_the_reference_interpreter_long(
    program, period, steps
):
    timer_programs_agree(program, period, steps)


def timer_programs_agree(program: tuple[str, list[str]], period: int, steps: list) -> None:
    text, watched = program
    built = build(from_string("prog.asi", text))
    assert not built.has_errors, built.render()
    probe = _simulation(built, f"[master]\ncycle_ms = {period / 1000}\n")
    probe.start()  # the clock's phase at time 0 is the same in every run of this program
    values = reference(text, period, _phase(probe), steps, watched)
    result = _simulation(built, scenario_text(period, steps, values)).run()
    assert not result.stops, result.stops
    assert [str(f) for f in result.failures] == []


# ------------------------------------------------------------------ whether it steps

LONG = SETUP + "[PROGRAM]\n    A I 1.0\n    AN T 1\n    L KT 40000\n    S T 1\n***\n" \
               "    A T 1\n    = Q 2.0\n"
START = '[master]\ncycle_ms = 5\n[[step]]\nat_ms = 10\nset = { "I 1.0" = 1 }\n'


def _cycles_run(built: Build, *, trace: bool = False, scenario: str = START) -> tuple[int, int]:
    """(AS-i cycles that ran, the timer's remaining ms) over the first 30 s."""
    assert built.image is not None
    simulation = Simulation(built, read_scenario(from_string("s.toml", scenario),
                                                 variables_of(built.image.pmap)), trace=trace)
    simulation.start()
    observe, count = simulation.board.observer, [0]

    def counted() -> None:
        count[0] += 1
        if observe is not None:
            observe()

    simulation.board.observer = counted
    simulation.run_to(30_000)
    from asictl.observe.operands import parse_operand
    return count[0], simulation.read(parse_operand("TV 1"))


def test_an_unread_timer_is_stepped_over_and_a_read_or_watched_one_ticks_one_by_one():
    unread = build(from_string("prog.asi", LONG))
    read = build(from_string("prog.asi", LONG + "***\n    L T 1\n    T FW 10\n"))
    assert unread.image is not None and unread.image.pmap.unread_timers == {1}
    assert read.image is not None and read.image.pmap.unread_timers == set()
    stepped, left = _cycles_run(unread)
    ticked, left_read = _cycles_run(read)
    traced, left_traced = _cycles_run(unread, trace=True)
    assert left == left_read == left_traced == 40000 - 29990  # started at 10 ms
    assert stepped < 100  # a handful around the start and each step
    assert ticked > 2900 and traced > 2900  # a cycle after each of the 3000 ticks
    window = START + '[[step]]\nat_ms = 20000\nwithin_ms = 100\nexpect = { "TV 1" = 20000 }\n'
    windowed, _ = _cycles_run(unread, scenario=window)
    assert windowed > 2900  # a tolerance window samples after every cycle that runs


def test_an_image_that_does_not_say_which_timers_are_read_ticks_them_one_by_one():
    built = build(from_string("prog.asi", LONG))
    assert built.image is not None
    pmap = replace(built.image.pmap, unread_timers=set())
    old = ProgramImage.from_bytes(replace(built.image, pmap=pmap, format_version=2).to_bytes())
    assert old.format_version == 2 and old.pmap.unread_timers == set()
    older = replace(built, image=old)
    (stepped, left), (ticked, left_old) = _cycles_run(built), _cycles_run(older)
    assert left == left_old and stepped < 100 < 2900 < ticked
