"""Reading scenario files: time against the number of steps, both schema forms.

Each step is found by its line in one pass over the text, so reading time grows
linearly with the number of steps (an inline ``step = [...]`` array once took 90 s for
20,000 steps). Usage:

    python3 benchmarks/bench_scenario.py [--steps 5000 10000 20000 40000]
"""

from __future__ import annotations

import argparse
import time

from asictl.sim.scenario import read_scenario
from asictl.source import from_string


def inline(n: int) -> str:
    return "step = [\n" + "".join(
        f'  {{ at_ms = {i}, set = {{ "I 1.0" = {i % 2} }} }},\n' for i in range(n)) + "]\n"


def tables(n: int) -> str:
    return "".join(f'[[step]]\nat_ms = {i}\nset = {{ "I 1.0" = {i % 2} }}\n' for i in range(n))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--steps", type=int, nargs="+", default=[5000, 10000, 20000, 40000])
    args = parser.parse_args()
    print(f"{'steps':>7} {'inline s':>9} {'us/step':>8} {'[[step]] s':>10} {'us/step':>8}")
    for n in args.steps:
        row = [f"{n:>7}"]
        for make in (inline, tables):
            text = make(n)
            start = time.perf_counter()
            scenario = read_scenario(from_string("s.toml", text))
            seconds = time.perf_counter() - start
            assert len(scenario.steps) == n
            row += [f"{seconds:>9.2f}" if make is inline else f"{seconds:>10.2f}",
                    f"{seconds / n * 1e6:>8.1f}"]
        print(" ".join(row))


if __name__ == "__main__":
    main()
