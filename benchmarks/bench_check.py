"""Time ``asictl check`` on a generated 10,000-line program, and ``asictl --help``.

Both are timed as whole processes (Python start-up included), as a user or CI sees them:
the median of several runs after one warm-up run. Usage:

    python3 benchmarks/bench_check.py [--lines 10000] [--runs 7]

CPU time (user + system of the process) is given beside the wall time: it hardly depends
on what else the machine runs, so it shows a change in asictl's own cost.

The console script installed beside the running Python is timed, not whatever ``asictl``
the PATH finds first: a version manager's shim there (pyenv's is a bash script that runs
``pyenv exec``) would add tens of milliseconds that are no part of asictl. The runs may
write Python's bytecode cache even where PYTHONDONTWRITEBYTECODE is set, as an installed
package has it: compiling asictl's modules anew in every run would add some 30 ms.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def generate(lines: int) -> str:
    """A realistic program: bit-logic networks, byte operations, timers, counters, jumps.

    It is clean up to 20,000 lines (no error, no warning), so the time is that of checking and
    analysing it, not of printing diagnostics: each network keeps its result in a flag bit of
    its own that a later network reads, and sets or resets an output.
    """
    out = ["[OPTIONS]", "auto_start: yes", "[SETUP]"]
    out += [f"{a}: iioo, 1, Eh" for a in range(1, 32)]
    out += ["[DECL]", "T100 TIMER", "C100 COUNTER", "Buffer BYTE 16", "[PROGRAM]"]
    n = 0
    while len(out) < lines:
        a, b, earlier = n % 31 + 1, (n * 7) % 31 + 1, n // 2  # reads network n/2's flag
        f = earlier // 8 % 128
        out += [
            f"    A   I {a}.0        ; network {n}",
            f"    AN  I {b}.1",
            f"    O   F {f}.{earlier % 8}",
            f"    =   F {n // 8 % 128}.{n % 8}",
            f"    S   Q {a}.2",
            "***",
            f"    L   FY {f}",
            f"    L   KB {n % 256}",
            "    +   F",
            f"    T   Buffer {n % 16}",
            "    L   KT 500",
            f"    A   I {b}.0",
            "    S   T 100",
            f"    JC  = l{n}",
            "    CU  C 100",
            "***",
            f"l{n}: A T 100",
            "    O   C 100",
            f"    R   Q {b}.3",
            "***",
        ]
        n += 1
    out.append("    BE")
    return "\n".join(out) + "\n"


def timed(command: list[str], runs: int) -> float:
    """Median wall time of the command."""
    return timed_with_cpu(command, runs)[0]


def timed_with_cpu(command: list[str], runs: int) -> tuple[float, float]:
    """Median wall time and median CPU time (user + system) of the command.

    The CPU time hardly depends on what else the machine runs, so it tells a change of
    asictl's own cost apart from a busy machine.
    """
    env = {name: value for name, value in os.environ.items()
           if name != "PYTHONDONTWRITEBYTECODE"}
    # warm the file cache and write the bytecode cache
    subprocess.run(command, check=False, capture_output=True, env=env)
    walls, cpus = [], []
    for _ in range(runs):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        result = subprocess.run(command, check=False, capture_output=True, env=env)
        walls.append(time.perf_counter() - start)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
        if result.returncode not in (0, 1):
            sys.exit(f"{' '.join(command)} failed:\n{result.stderr.decode()}")
    return statistics.median(walls), statistics.median(cpus)


def cpu_seconds(pid: int) -> float:
    """User and system time of a process so far (/proc/PID/stat, fields 14 and 15)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def console_script() -> str | None:
    """The ``asictl`` script of this Python's environment, else the first on the PATH."""
    beside = Path(sys.executable).parent / "asictl"
    return str(beside) if beside.is_file() else shutil.which("asictl")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lines", type=int, default=10_000)
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    asictl = console_script() or sys.exit("asictl is not installed (pip install -e .)")
    with tempfile.TemporaryDirectory() as tmp:
        program = Path(tmp) / "big.asi"
        program.write_text(generate(args.lines))
        lines = program.read_text().count("\n")
        check, check_cpu = timed_with_cpu([asictl, "check", "-q", str(program)], args.runs)
        help_, help_cpu = timed_with_cpu([asictl, "--help"], args.runs)
    print(f"asictl check, {lines} lines: {check:.3f} s, CPU {check_cpu:.3f} s "
          f"(medians of {args.runs}; target < 0.5 s)")
    print(f"asictl --help:            {help_:.3f} s, CPU {help_cpu:.3f} s "
          f"(medians of {args.runs}; target < 0.25 s)")


if __name__ == "__main__":
    main()
