"""Whether a scenario passes on each of some programs under the simulator: how the tests
check that a distinguishing scenario written by ``diff --equivalent`` replays."""

from __future__ import annotations

from pathlib import Path

from asictl.build import build_file
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
