"""Time ``asictl.il.parser.parse`` alone on the generated program of bench_check.py.

In-process, so without Python start-up and imports: the best of several runs of CPU time
(``time.process_time``, steadier than wall time on a shared machine) and of wall time,
after one warm-up run that also builds or loads the cached grammar. Usage:

    python3 benchmarks/bench_parse.py [--lines 10000] [--runs 7]
"""

from __future__ import annotations

import argparse
import time

from bench_check import generate

from asictl.il.parser import parse_text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lines", type=int, default=10_000)
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    text = generate(args.lines)
    parse_text(text)
    cpu, wall = [], []
    for _ in range(args.runs):
        start_cpu, start_wall = time.process_time(), time.perf_counter()
        _, diagnostics = parse_text(text, "big.asi")
        cpu.append(time.process_time() - start_cpu)
        wall.append(time.perf_counter() - start_wall)
    assert not diagnostics, diagnostics[:3]
    lines = text.count("\n")
    print(f"parse, {lines} lines: {min(cpu):.3f} s CPU, {min(wall):.3f} s wall "
          f"(best of {args.runs}; target < 0.4 s)")


if __name__ == "__main__":
    main()
