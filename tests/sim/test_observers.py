"""The simulation core calls its observers (sim/observer.py) as it promises: a feature a
run does not use costs nothing after each cycle, and the hooks come in their order."""

from __future__ import annotations

from pathlib import Path

from asictl.build import build_file
from asictl.sim.engine import Simulation
from asictl.sim.scenario import Scenario, Step, read_scenario
from asictl.source import from_string

BLINK = Path(__file__).resolve().parents[1] / "scenarios" / "blink.asi"


def test_a_run_without_plant_window_trace_or_coverage_has_no_hook_after_each_cycle():
    simulation = Simulation(build_file(BLINK), Scenario("<s>", None, 5.0, None, [Step(10.0, 1)]))
    simulation.start()
    assert simulation._after_any_cycle == [] and simulation._after_cycle == []
    assert simulation._next_changes == [] and simulation._changed == []


def test_each_feature_watches_the_cycles_only_when_it_is_asked_for():
    scenario = read_scenario(from_string("s.toml", (
        '[master]\ncycle_ms = 5\n'
        '[[step]]\nat_ms = 250\nexpect = { "Q 31.0" = 1 }\nwithin_ms = 20\n'
    )))
    simulation = Simulation(build_file(BLINK), scenario, trace=True, coverage=True)
    simulation.start()
    watching = {type(hook.__self__).__name__ for hook in simulation._after_cycle}
    assert watching == {"Windows", "SignalTrace"}
    assert [type(h.__self__).__name__ for h in simulation._after_any_cycle] == ["CoverageWatch"]
    simulation.run_to(300)
    result = simulation.finish()
    assert result.checked == 1 and result.trace is not None and result.coverage is not None
