"""Time ``asictl check`` on files with very many errors: rendering must stay linear.

Each file is a [PROGRAM] of N lines with one error each, of one kind: syntax errors
(the parser's error recovery), operands out of range and undefined variables (the
semantic checks). ``asictl check`` is timed as a whole process, with text output (the
default, which shows the first 200 diagnostics of a file and counts the rest), with all
of them as text (--max-diagnostics 0) and as JSON. Doubling N should about double each
time. Usage:

    python3 benchmarks/bench_diagnostics.py [--errors 10000 40000 160000] [--runs 3]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

KINDS: dict[str, Callable[[int], str]] = {
    "syntax": lambda n: "x\n" * n,
    "range": lambda n: "  L KB 999\n" * n,
    "undefined": lambda n: "".join(f"  A v{i}\n" for i in range(n)),
}
MODES = {
    "text": [],
    "text, all": ["--max-diagnostics", "0"],
    "json": ["--format", "json"],
}


def timed(command: list[str], runs: int) -> float:
    samples = []
    for _ in range(runs):
        start = time.perf_counter()
        result = subprocess.run(command, check=False, capture_output=True)
        samples.append(time.perf_counter() - start)
        if result.returncode != 1:
            sys.exit(f"{' '.join(command)} exited {result.returncode}:\n{result.stderr.decode()}")
    return statistics.median(samples)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--errors", type=int, nargs="+", default=[10_000, 40_000, 160_000])
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    asictl = [sys.executable, "-m", "asictl", "check", "-q"]
    print(f"{'kind':<10} {'errors':>7} {'size':>8}  " + "  ".join(f"{m:>9}" for m in MODES))
    with tempfile.TemporaryDirectory() as tmp:
        for kind, body in KINDS.items():
            for n in args.errors:
                program = Path(tmp) / f"{kind}-{n}.asi"
                program.write_text("[PROGRAM]\n" + body(n))
                size = f"{program.stat().st_size // 1024} KB"
                times = [timed([*asictl, *flags, str(program)], args.runs)
                         for flags in MODES.values()]
                print(f"{kind:<10} {n:>7} {size:>8}  "
                      + "  ".join(f"{t:>8.2f}s" for t in times), flush=True)


if __name__ == "__main__":
    main()
