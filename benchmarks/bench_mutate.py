"""``asictl mutate demos -j 2``: the wall time of mutation testing every demo program
against its scenarios (bar: under 60 s on the 2-core machine), and the CPU time of the
whole process tree; then the same again, every verdict now from the cache.

The command runs as a process of its own, as a user runs it, with a cache folder of its
own that starts empty (the first run judges every mutant); its JSON report gives the
number of mutants, the verdicts and the score, and each mutant's time shows where the
wall time goes (the slowest programs, by the seconds their mutants took in all).
Usage:

    python3 benchmarks/bench_mutate.py [--jobs 2] [--folder demos]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--folder", type=Path, default=ROOT / "demos")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as cache:
        command = [sys.executable, "-m", "asictl", "mutate", str(args.folder),
                   "-j", str(args.jobs), "--format", "json", "--cache", cache]
        report, wall, cpu = _run(command)
        again, rerun_wall, rerun_cpu = _run(command)
    verdicts = Counter(m["verdict"] for m in report["mutants"])
    by_file: dict[str, float] = defaultdict(float)
    for mutant in report["mutants"]:
        by_file[mutant["file"]] += mutant["seconds"]
    print(f"{len(report['mutants'])} mutants of {len(by_file)} programs, -j {args.jobs}: "
          f"{wall:.1f} s wall, {cpu:.1f} s CPU (bar: under 60 s wall)")
    print("verdicts: " + ", ".join(f"{n} {v}" for v, n in sorted(verdicts.items())))
    print(f"score {report['score']}% ({report['killed']}/{report['counted']})")
    undecided = [m for m in report["mutants"] if m["verdict"] == "survived"
                 and m["detail"] in ("", "the proof of equivalence ran out of time")]
    print(f"survivors the prover was asked about and could not decide: {len(undecided)} "
          f"({sum(m['seconds'] for m in undecided):.1f} s)")
    print("slowest programs (seconds of all their mutants):")
    for file, seconds in sorted(by_file.items(), key=lambda item: -item[1])[:5]:
        print(f"  {file}: {seconds:.1f} s")
    print(f"again, {again['from_cache']} of {len(again['mutants'])} verdicts from the cache: "
          f"{rerun_wall:.1f} s wall, {rerun_cpu:.1f} s CPU")


def _run(command: list[str]) -> tuple[dict[str, Any], float, float]:
    """The JSON report of one run, its wall time and the CPU time of its processes."""
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, env=env, check=False)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if done.returncode not in (0, 1):
        sys.exit(f"asictl mutate failed ({done.returncode}):\n{done.stderr}")
    report: dict[str, Any] = json.loads(done.stdout)
    return report, wall, cpu


if __name__ == "__main__":
    main()
