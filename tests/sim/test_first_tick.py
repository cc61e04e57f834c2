"""``[master] first_tick_ms``: the time from time 0 to the master's first 10 ms tick. A
real master's clock runs on its own, so a run that depends on its phase (a timer read
between ticks) replays only where the phase is the same: a scenario can say which. The
reference interpreter, ticked where the timing contract puts the ticks, is the oracle;
a properties file has no such key (a proof holds for every phase)."""

from __future__ import annotations

from pathlib import Path

import pytest

from asictl.build import Build, build_file
from asictl.diagnostics import DiagnosticError
from asictl.il.oracle import Interpreter
from asictl.prove.props import read_properties
from asictl.sim.engine import Simulation, variables_of
from asictl.sim.scenario import load_scenario
from asictl.source import read_source

#: T 1 starts with 50 ms while I 1.0 is on (and restarts every cycle it stays on)
PROGRAM = """[SETUP]
1: iiii, 0
2: oooo, 0

[PROGRAM]
        L   KT 50
        A   I 1.0
        S   T 1
***
"""
CYCLE_MS, CYCLES = 3, 7


def _built(folder: Path) -> Build:
    (folder / "p.asi").write_text(PROGRAM)
    return build_file(folder / "p.asi")


def _timer_left(built: Build, first_tick_ms: float) -> int:
    """T 1's ms left after CYCLES cycles, I 1.0 on in the first only, the ticks at
    first_tick_ms + 10 k ms: the oracle's run."""
    assert built.program is not None
    interp = Interpreter(built.program)
    tick = first_tick_ms
    for n in range(CYCLES):
        ticks = 0
        while tick <= n * CYCLE_MS:
            ticks += 1
            tick += 10
        interp.tick(ticks)
        interp.cycle(bytes([0x10 if n == 0 else 0]) + bytes(15))
    return interp.state.timers.get(1, 0) * 10


@pytest.mark.parametrize("first_tick_ms", [0.5, 2.5, 6.7, 9.9, 10])
def test_the_first_tick_falls_where_the_scenario_says(tmp_path: Path, first_tick_ms: float):
    built = _built(tmp_path)
    expected = _timer_left(built, first_tick_ms)
    (tmp_path / "p.scenario.toml").write_text(
        f"[master]\ncycle_ms = {CYCLE_MS}\nfirst_tick_ms = {first_tick_ms}\n"
        '[[step]]\nat_ms = 0\nset = { "I 1.0" = 1 }\n'
        f'[[step]]\nat_ms = {CYCLE_MS}\nset = {{ "I 1.0" = 0 }}\n'
        f"[[step]]\nat_ms = {(CYCLES - 1) * CYCLE_MS + 0.001}\n"
        f'expect = {{ "TV 1" = {expected} }}\n')
    assert built.image is not None
    scenario = load_scenario(tmp_path / "p.scenario.toml", variables_of(built.image.pmap))
    assert scenario.first_tick_ms == first_tick_ms
    result = Simulation(built, scenario).run()
    assert result.passed, [str(f) for f in result.failures]


def test_two_phases_two_results_and_a_properties_file_refuses_the_key(tmp_path: Path):
    """The oracle's runs differ between phases (so the test above tells them apart); a
    properties file with the key is an unknown-key error."""
    built = _built(tmp_path)
    assert len({_timer_left(built, ms) for ms in (0.5, 2.5, 6.7, 9.9)}) > 1
    props = tmp_path / "p.props.toml"
    props.write_text('[master]\nfirst_tick_ms = 5\n[[property]]\nname = "x"\nnever = "Q 2.0"\n')
    with pytest.raises(DiagnosticError) as error:
        read_properties(read_source(props))
    assert "first_tick_ms" in error.value.diagnostics[0].message
