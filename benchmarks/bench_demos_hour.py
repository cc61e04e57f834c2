"""Simulation speed of the demos: one hour of master time of each, with its scenario.

Each ``demos/*.asi`` runs as ``asictl sim demos/NAME.asi --duration 1h`` would (its
scenario's inputs and expectations, then on to the hour; a scenario longer than the hour
runs to its end). The CPU time of the run alone is printed (the build is left out), with
the program cycles the master executed: the master skips cycles that would change
nothing, so a demo whose state settles costs what its changes cost. Usage:

    python3 benchmarks/bench_demos_hour.py [--hours 1] [DEMO ...]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from asictl.sim.engine import Simulation
from asictl.sim.session import prepare, scenario_for

DEMOS = Path(__file__).resolve().parent.parent / "demos"


def run_demo(program: Path, hours: float) -> tuple[float, int, bool]:
    """CPU seconds of the run, program cycles executed, whether the scenario held."""
    scenario = scenario_for(program)
    prepared = prepare(program, scenario if scenario.exists() else None)
    prepared = prepare(program, scenario if scenario.exists() else None,
                       duration_ms=max(hours * 3_600_000, prepared.end_ms))
    cpu = time.process_time()
    sim = Simulation(prepared.build, prepared.scenario, duration_ms=prepared.end_ms,
                     symbols=prepared.symbols)
    sim.start()
    runner = sim.board.program
    assert runner is not None
    executed = 0
    original = runner.cycle

    def counting(*args: object, **kwargs: object) -> object:
        nonlocal executed
        executed += 1
        return original(*args, **kwargs)

    runner.cycle = counting  # type: ignore[method-assign]
    sim.run_to(prepared.end_ms)
    result = sim.finish()
    return time.process_time() - cpu, executed, result.passed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("demos", nargs="*", help="demo names (default: all)")
    args = parser.parse_args()
    names = args.demos or sorted(p.stem for p in DEMOS.glob("*.asi"))
    total = 0.0
    for name in names:
        cpu, cycles, held = run_demo(DEMOS / f"{name}.asi", args.hours)
        total += cpu
        print(f"{name:10} {cpu:6.2f} s CPU  {cycles:>9,} cycles executed"
              f"{'' if held else '  (scenario FAILED)'}")
    print(f"{'total':10} {total:6.2f} s CPU")


if __name__ == "__main__":
    main()
