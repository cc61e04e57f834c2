"""Closed-loop simulation speed: a cylinder that strokes back and forth for an hour.

The program extends the cylinder while its retracted switch is closed and lets it spring
back once it is out, forever; the cylinder takes 300 ms each way, so an hour of master
time at a 5 ms cycle is 6,000 double strokes, 24,000 end-switch changes and 720,000
program cycles. The master skips the cycles that change nothing, and the plant model is
evaluated after the cycles that ran and at its own changes only, so the run costs what
its events cost, not its cycles. With ``--trace`` the run records the trace too (the
model's position then sampled every cycle while it moves). Usage:

    python3 benchmarks/bench_plant.py [--hours 1] [--trace]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from asictl.build import build_file
from asictl.sim.engine import Simulation, variables_of
from asictl.sim.scenario import load_scenario

PROGRAM = """[SETUP]
1: iiii, 0
2: oooo, 0

[PROGRAM]
        A   I 1.1           ; in: out again
        S   Q 2.0
***
        A   I 1.0           ; out: back
        R   Q 2.0
"""

SCENARIO = """[master]
cycle_ms = 5
[[plant]]
type = "cylinder"
extend = "Q 2.0"
extended = "I 1.0"
retracted = "I 1.1"
stroke_ms = 300
[[step]]
at = "{hours}h"
"""


def run(hours: float, trace: bool) -> tuple[float, float, int, int]:
    with tempfile.TemporaryDirectory() as tmp:
        program, scenario = Path(tmp) / "stroke.asi", Path(tmp) / "stroke.scenario.toml"
        program.write_text(PROGRAM)
        scenario.write_text(SCENARIO.format(hours=hours))
        built = build_file(program)
        assert built.image is not None
        loaded = load_scenario(scenario, variables_of(built.image.pmap))
    simulation = Simulation(built, loaded, trace=trace)
    evaluations = 0
    update = simulation.plant.update

    def counted(now_ms: float, io: object) -> None:
        nonlocal evaluations
        evaluations += 1
        update(now_ms, io)  # type: ignore[arg-type]

    simulation.plant.update = counted  # type: ignore[method-assign]
    start, cpu = time.perf_counter(), time.process_time()
    simulation.run()
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    model = simulation.plant.models[0]
    strokes = round(model._t / 600_000)  # a double stroke every 600 ms
    return seconds, cpu, strokes, evaluations


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--trace", action="store_true")
    args = parser.parse_args()
    seconds, cpu, strokes, evaluations = run(args.hours, args.trace)
    print(f"{args.hours:g} h of master time, {strokes} double strokes, {evaluations} model "
          f"evaluations{' (traced)' if args.trace else ''}: {seconds:.2f} s "
          f"({cpu:.2f} s of CPU time)")


if __name__ == "__main__":
    main()
