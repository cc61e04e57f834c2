"""``asictl test -j N``: wall time of a folder of 30 scenarios, one after the other (-j 1)
against worker processes (-j 2, -j N).

Each scenario runs a program that changes its state every cycle (so the master cannot
skip cycles) for 120 s of master time at a 5 ms cycle: 24,000 program cycles. Most
scenarios hold, a few fail, so the exit status (1) is compared too. Each -j runs
``--repeat`` times; the best wall time counts (other work on the machine only ever makes
a run slower). Usage:

    python3 benchmarks/bench_test_parallel.py [--scenarios 30] [--jobs 1 2 4] [--repeat 3]
"""

from __future__ import annotations

import argparse
import concurrent.futures
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PROGRAM = """\
[SETUP]
1: iiii, 0
2: oooo, 0
[PROGRAM]
    L   FY 10           ; a cycle counter: the state changes every cycle
    L   KB 1
    +   F
    T   FY 10
***
    A   I 1.0
    CU  C 0
***
    A   C 0
    =   Q 2.0
"""


def scenario(i: int) -> str:
    expected = 1 if i % 7 else 0  # every seventh scenario fails
    return (
        "[master]\ncycle_ms = 5\n"
        f'[[step]]\nat_ms = {i * 10}\nset = {{ "I 1.0" = 1 }}\n'
        f'[[step]]\nat_ms = 120000\nexpect = {{ "Q 2.0" = {expected} }}\n'
    )


def _burn(n: int) -> int:
    total = 0
    for i in range(n):
        total += i * i
    return total


def machine_parallelism(workers: int) -> float:
    """How much faster ``workers`` processes burn CPU than one does, right now: what this
    machine (shared with other work) can give, whatever asictl does."""
    n = 5_000_000
    start = time.perf_counter()
    for _ in range(workers):
        _burn(n)
    serial = time.perf_counter() - start
    start = time.perf_counter()
    with concurrent.futures.ProcessPoolExecutor(workers) as pool:
        list(pool.map(_burn, [n] * workers))
    return serial / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--scenarios", type=int, default=30)
    parser.add_argument("--jobs", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for i in range(args.scenarios):
            (folder / f"count{i:02}.asi").write_text(PROGRAM)
            (folder / f"count{i:02}.scenario.toml").write_text(scenario(i))
        env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}
        base = None
        print(f"{args.scenarios} scenarios, {os.cpu_count()} cores, load average "
              f"{os.getloadavg()[0]:.1f} (other processes share the cores: compare CPU s)")
        print(f"{'-j':>4} {'wall s':>8} {'of -j 1':>8} {'CPU s':>7} {'exit':>5}")
        outputs = set()
        for jobs in args.jobs:
            best = None
            for _ in range(args.repeat):
                before = os.times()
                start = time.perf_counter()
                done = subprocess.run(
                    [sys.executable, "-m", "asictl", "test", str(folder), "-j", str(jobs)],
                    env=env, capture_output=True, text=True,
                )
                seconds = time.perf_counter() - start
                after = os.times()
                cpu = (after.children_user - before.children_user
                       + after.children_system - before.children_system)
                outputs.add(re.sub(r"in \d+\.\d+ s", "", done.stdout))
                if best is None or seconds < best[0]:
                    best = (seconds, cpu, done.returncode)
            assert best is not None
            seconds, cpu, status = best
            base = base or seconds
            print(f"{jobs:>4} {seconds:>8.2f} {seconds / base:>8.2f} {cpu:>7.2f} {status:>5}")
        print("same output for every -j:", len(outputs) == 1)
        print(f"the machine's own speed-up for 2 processes burning CPU: "
              f"{machine_parallelism(2):.2f}x")


if __name__ == "__main__":
    main()
