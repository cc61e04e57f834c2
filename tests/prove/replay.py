"""A scenario the prover wrote, replayed by the simulator (the compiled 8051 code on the
emulated master): a witness must pass, a counterexample fail at its last step only."""

from __future__ import annotations

from pathlib import Path

from asictl.build import build_file
from asictl.prove.engine import Verdict
from asictl.sim.engine import Simulation, variables_of
from asictl.sim.scenario import load_scenario


def assert_replays(program: Path, scenario_path: Path, verdict: Verdict) -> None:
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
