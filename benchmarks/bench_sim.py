"""Simulation speed: one hour of master time against awlsim running the same logic.

The program has 50 bit-logic networks, a 500 ms blinker on a timer, and a flag that
toggles every cycle, so no program cycle leaves the machine unchanged (the master skips
cycles that would change nothing; this benchmark makes every cycle count). With a fixed
5 ms cycle an hour is 720,000 program cycles. awlsim (pip package ``awlsim``) runs the
equivalent STL program with ``AwlSim.runCycle()`` for a fixed number of cycles, in this
Python when it has awlsim, else in awlsim's own (``ASICTL_AWLSIM_PYTHON``, or the one
beside ``awlsim-test`` on PATH, as ``asictl export --check`` finds it). Both are timed in
CPU seconds, so that the ratio holds on a loaded machine. Usage:

    python3 benchmarks/bench_sim.py [--hours 1] [--awlsim-cycles 50000] [--coverage]

``--coverage`` runs the hour twice more, interleaved, without and with coverage collected
(docs/testing.md), and prints what coverage costs in program cycles per CPU second.
"""

from __future__ import annotations

import argparse
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

NETWORKS = 50


def networks(seed: int = 7) -> list[tuple[str, tuple[int, int], tuple[int, int], tuple[int, int],
                                     tuple[int, int]]]:
    rng = random.Random(seed)
    return [
        (rng.choice("AO"), (rng.randrange(1, 16), rng.randrange(4)),
         (rng.randrange(1, 16), rng.randrange(4)), (rng.randrange(16), rng.randrange(8)),
         (rng.randrange(16, 31), rng.randrange(4)))
        for _ in range(NETWORKS)
    ]


def il_program() -> str:
    lines = ["[SETUP]", *(f"{a}: iiii, 0" for a in range(1, 16)),
             *(f"{a}: oooo, 0" for a in range(16, 31)), "[PROGRAM]"]
    for op, i1, i2, flag, q in networks():
        lines += [f"    A I {i1[0]}.{i1[1]}", f"    AN I {i2[0]}.{i2[1]}",
                  f"    {op} F {flag[0]}.{flag[1]}", f"    = Q {q[0]}.{q[1]}", "***"]
    lines += ["    AN F 20.0", "    = F 20.0", "***",  # toggles every cycle
              "    A T 0", "    JC = end", "    N", "    L KT 500", "    S T 0", "***",
              "    AN Q 31.0", "    = Q 31.0", "end: BE"]
    return "\n".join(lines) + "\n"


def stl_program() -> str:
    lines = ["ORGANIZATION_BLOCK OB 1", "BEGIN"]
    for op, i1, i2, flag, q in networks():
        lines += [f"\tU E {i1[0]}.{i1[1]}", f"\tUN E {i2[0]}.{i2[1]}",
                  f"\t{'U' if op == 'A' else 'O'} M {flag[0]}.{flag[1]}",
                  f"\t= A {q[0]}.{q[1]}"]
    lines += ["\tUN M 20.0", "\t= M 20.0",
              "\tUN T 0", "\tL S5T#500MS", "\tSV T 0",
              "\tU T 0", "\tFP M 21.0", "\tSPBN m001",
              "\tUN A 31.0", "\t= A 31.0", "m001:\tNOP 0", "END_ORGANIZATION_BLOCK"]
    return "\n".join(lines) + "\n"


def run_asictl(hours: float, coverage: bool = False) -> tuple[float, int, int, float]:
    """Wall seconds, program cycles, cycles executed, cycles per CPU second.

    The hour is run twice on fresh boards: timed as a user runs it, then once more
    counting the program cycles that executed (a wrapper around the runner's cycle,
    whose call would otherwise be part of the time)."""
    # imported here: awlsim's Python runs this script for its side (--awlsim-only)
    from asictl.build import build_file
    from asictl.sim.engine import Simulation
    from asictl.sim.scenario import Scenario

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.asi"
        path.write_text(il_program())
        built = build_file(path)
    duration = hours * 3_600_000
    scenario = Scenario("<bench>", None, 5.0, None, [])

    def started() -> Simulation:
        sim = Simulation(built, scenario, duration_ms=duration, coverage=coverage)
        sim.start()
        return sim

    sim = started()
    start, cpu = time.perf_counter(), time.process_time()
    sim.board.advance(duration)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    rate = round(duration / 5) / cpu
    label = "asictl with coverage" if coverage else "asictl"
    print(f"{label}: {cpu:.1f} s of CPU time: {rate:,.0f} cycles per CPU second")
    if coverage:
        totals = sim.finish().coverage.totals()  # type: ignore[union-attr]
        print("  " + ", ".join(f"{kind} {hit}/{count}" for kind, (hit, count) in totals.items()))
    counted = started()
    runner = counted.board.program
    executed = 0
    original = runner.cycle

    def counting(inputs=None):
        nonlocal executed
        executed += 1
        original(inputs)

    runner.cycle = counting
    counted.board.advance(duration)
    return wall, round(duration / 5), executed, rate


def run_awlsim(cycles: int) -> float:
    """awlsim's cycles per CPU second, in this Python or in awlsim's own."""
    try:
        return awlsim_rate(cycles)
    except ImportError:
        pass
    from asictl.errors import UserError
    from asictl.export.check import awlsim_python

    try:
        python = awlsim_python()
    except UserError:
        raise ImportError("no awlsim") from None
    done = subprocess.run([python, __file__, "--awlsim-only", "--awlsim-cycles", str(cycles)],
                          capture_output=True, text=True, check=True)
    return float(done.stdout)


def awlsim_rate(cycles: int) -> float:
    # awlsim's own imports work only when its core comes before its parser
    from awlsim.core.main import AwlSim  # isort: skip
    from awlsim.awlcompiler.tokenizer import AwlParser  # isort: skip

    parser = AwlParser()
    parser.parseData(stl_program().encode())
    sim = AwlSim()
    sim.load(parser.getParseTree())
    sim.startup()
    start = time.process_time()
    for _ in range(cycles):
        sim.runCycle()
    return cycles / (time.process_time() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--awlsim-cycles", type=int, default=50_000)
    parser.add_argument("--coverage", action="store_true",
                        help="also measure what collecting coverage costs")
    parser.add_argument("--awlsim-only", action="store_true",
                        help="print awlsim's cycles per CPU second alone (in awlsim's Python)")
    args = parser.parse_args()
    if args.awlsim_only:
        print(awlsim_rate(args.awlsim_cycles))
        return
    if args.coverage:
        plain, covered = [], []
        for _ in range(2):  # interleaved: the machine's load changes over minutes
            plain.append(run_asictl(args.hours)[3])
            covered.append(run_asictl(args.hours, coverage=True)[3])
        cost = 1 - sum(covered) / sum(plain)
        print(f"coverage costs {cost:.0%} of the cycles per CPU second (bar <= 25 %)")
        return
    wall, cycles, executed, ours = run_asictl(args.hours)
    print(f"asictl: {args.hours:g} h of master time, {cycles} program cycles "
          f"({executed} executed) in {wall:.1f} s wall")
    try:
        theirs = run_awlsim(args.awlsim_cycles)
    except ImportError:
        print("awlsim is not installed (pip install awlsim, or ASICTL_AWLSIM_PYTHON): "
              "no comparison", file=sys.stderr)
        return
    print(f"awlsim: {theirs:,.0f} cycles per CPU second "
          f"({args.awlsim_cycles} cycles of the same logic)")
    print(f"ratio:  {ours / theirs:.2f}x in CPU time (bar >= 8x, goal 20x)")


if __name__ == "__main__":
    main()
