"""Whether a scenario passes on each of some programs under the simulator: how the tests
check that a distinguishing scenario written by ``diff --equivalent`` replays, and that a
counterexample or witness written by ``prove`` does."""

from __future__ import annotations

from pathlib import Path

from asictl.build import build_file
from asictl.prove.engine import Verdict
from asictl.sim.engine import Simulation, variables_of
from asictl.sim.scenario import load_scenario


def passes(scenario_path: Path, *programs: Path) -> dict[str, bool]:
    """Each program's file name -> whether the scenario passes on it."""
    outcomes = {}
    for program in programs:
        built = build_file(program)
        assert built.image is not None
        scenario = load_scenario(scenario_path, variables_of(built.image.pmap))
        outcomes[program.name] = Simulation(built, scenario).run().passed
    return outcomes


def assert_replays(program: Path, scenario_path: Path, verdict: Verdict) -> None:
    """A witness (``REACHED``) passes on ``program``; a counterexample fails, at its last
    step only."""
    built = build_file(program)
    assert built.image is not None
    scenario = load_scenario(scenario_path, variables_of(built.image.pmap))
    result = Simulation(built, scenario).run()
    if verdict is Verdict.REACHED:
        assert result.passed, (scenario_path.read_text(), [str(f) for f in result.failures])
    else:
        last = max(step.at_ms for step in scenario.steps)
        assert result.failures and {f.at_ms for f in result.failures} == {last}, \
            scenario_path.read_text()
