"""How long ``asictl prove`` takes: every demo's properties file, and a 500-line program
with 20 properties.

The large program has 25 reversing-motor units (two directions, each latched against
the other, a common stop, a 2 s on-delay before the motor runs in five of them) in
about 500 lines; its 20 properties are the units' mutual exclusions, their stops and
five timer responses. Each file is decided by the same call as ``asictl prove``, with
counterexamples written to a temporary folder. Usage:

    python3 benchmarks/bench_prove.py [--demos-only] [--timeout 60]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from asictl.prove.session import prove

DEMOS = Path(__file__).resolve().parents[1] / "demos"
UNITS = 25
TIMED = 5


def large_program() -> tuple[str, str]:
    """The program and its properties file."""
    inputs = 2 + (UNITS + 1) // 2
    lines = ["; 25 reversing motors with interlocks (benchmarks/bench_prove.py)", "[SETUP]",
             "1: iiii, 0", *(f"{a}: iiii, 0" for a in range(2, inputs)),
             *(f"{a}: oooo, 0" for a in range(16, 16 + (UNITS + 1) // 2)), "[PROGRAM]"]
    props = ["[master]", "cycle_ms = 100"]
    for unit in range(UNITS):
        a, b = 2 + unit // 2, (unit % 2) * 2
        q = 16 + unit // 2
        flag = 10 + unit
        lines += [
            f"; unit {unit}: I {a}.{b} forward, I {a}.{b + 1} backward, I 1.2 stop",
            f"        A   I {a}.{b}", "        AN  I 1.2", f"        AN  F {flag}.1",
            f"        =   F {flag}.0", "***",
            f"        A   I {a}.{b + 1}", "        AN  I 1.2", f"        AN  F {flag}.0",
            f"        =   F {flag}.1", "***",
        ]
        if unit < TIMED:  # the motor runs 2 s after the direction was chosen
            lines += [
                "        L   KT 2000", f"        A   F {flag}.0", f"        AN  F {flag}.2",
                f"        S   T {unit}", f"        AN  F {flag}.0", f"        R   T {unit}",
                "***", f"        A   F {flag}.0", f"        =   F {flag}.2", "***",
                f"        A   F {flag}.0", f"        AN  T {unit}", f"        =   Q {q}.{b}",
                "***",
            ]
        else:
            lines += [f"        A   F {flag}.0", f"        =   Q {q}.{b}", "***"]
        lines += [f"        A   F {flag}.1", f"        =   Q {q}.{b + 1}", "***"]
    for unit in range(10):
        q, b = 16 + unit // 2, (unit % 2) * 2
        props += ["[[property]]", f'name = "unit {unit}: never both directions"',
                  f'never = "Q {q}.{b} and Q {q}.{b + 1}"']
    for unit in range(10, 15):
        q, b = 16 + unit // 2, (unit % 2) * 2
        props += ["[[property]]", f'name = "unit {unit}: stop wins"',
                  f'never = "I 1.2 and (Q {q}.{b} or Q {q}.{b + 1})"']
    for unit in range(TIMED):
        a, b = 2 + unit // 2, (unit % 2) * 2
        q = 16 + unit // 2
        props += ["[[property]]", f'name = "unit {unit}: runs 2 s after forward"',
                  f'when = "F {10 + unit}.0"', f'then = "Q {q}.{b} or not F {10 + unit}.0"',
                  'within = "2100ms"']
    return "\n".join(lines) + "\n", "\n".join(props) + "\n"


def run(props: Path, timeout: float) -> tuple[float, float, str]:
    """Wall-clock and CPU seconds (the machine is shared: the CPU time is what the
    prover itself took), and the verdicts."""
    with tempfile.TemporaryDirectory() as out:
        start, cpu = time.perf_counter(), time.process_time()
        report = prove(props, out_dir=Path(out), timeout_s=timeout)
        seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    counts: dict[str, int] = {}
    for outcome in report.outcomes:
        counts[outcome.verdict.value] = counts.get(outcome.verdict.value, 0) + 1
    return seconds, cpu, ", ".join(f"{n} {v}" for v, n in counts.items())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--demos-only", action="store_true")
    parser.add_argument("--timeout", type=float, default=60.0,
                        help="seconds for each property (wall clock: generous on a shared machine)")
    args = parser.parse_args()
    total = total_cpu = 0.0
    print(f"{'':28} {'wall':>8} {'CPU':>8}")
    for props in sorted(DEMOS.glob("*.props.toml")):
        seconds, cpu, verdicts = run(props, args.timeout)
        total += seconds
        total_cpu += cpu
        print(f"{props.name:28} {seconds:6.2f} s {cpu:6.2f} s  {verdicts}")
    print(f"{'all demos':28} {total:6.2f} s {total_cpu:6.2f} s")
    if args.demos_only:
        return
    program, properties = large_program()
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "motors.asi"
        path.write_text(program)
        (Path(folder) / "motors.props.toml").write_text(properties)
        seconds, cpu, verdicts = run(Path(folder) / "motors.props.toml", args.timeout)
    lines = program.count("\n")
    print(f"{'motors.asi':28} {seconds:6.2f} s {cpu:6.2f} s  {verdicts} ({lines} lines, "
          "20 properties)")


if __name__ == "__main__":
    main()
