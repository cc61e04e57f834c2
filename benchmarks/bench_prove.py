"""How long ``asictl prove`` takes: every demo's properties file, properties behind
timers, and a 500-line program with 20 properties.

The timer cases are an on-delay (the input on for the preset turns the output on) at
10 ms cycles: a response within 600 ms behind a 500 ms delay (proved by the facts that
tie a waiting trigger to its timer), one within 490 ms (refuted at cycle 50), and
counterexamples behind a 20 s and a 40 s delay (2,000 and 4,000 cycles, found with steps
of idle cycles); and the 1 h timer demo (100 runs of a 36 s timer counted by a counter,
at 1 s and at 10 ms cycles) with a property the end of the hour breaks.

The large program has 25 reversing-motor units (two directions, each latched against
the other, a common stop, a 2 s on-delay before the motor runs in five of them) in
about 500 lines; its 20 properties are the units' mutual exclusions, their stops and
five timer responses. Each file is decided by the same call as ``asictl prove``, with
counterexamples written to a temporary folder. Usage:

    python3 benchmarks/bench_prove.py [--demos-only | --timers-only] [--timeout 60]
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


#: The on-delay demo (Q 2.0 when I 1.0 has been on for the preset), its preset a field.
ONDELAY = (DEMOS / "ondelay.asi").read_text().replace("KT 2000", "KT {preset}")


def _response(ms: int) -> str:
    return (f'[[property]]\nname = "on within {ms} ms"\nwhen = "I 1.0"\n'
            f'then = "Q 2.0 or not I 1.0"\nwithin = "{ms}ms"\n')


NEVER_ON = '[[property]]\nname = "never on"\nnever = "Q 2.0"\n'
HOUR = (DEMOS / "1h_timer.asi").read_text()
HOUR_ENDS = '[[property]]\nname = "the hour never ends"\nnever = "Q 2.1"\n'
#: name, program, cycle_ms, properties, depth (cycles; None: not given)
TIMED_CASES: list[tuple[str, str, int, str, int | None]] = [
    ("600 ms response, 500 ms delay", ONDELAY.format(preset=500), 10, _response(600), None),
    ("490 ms response, 500 ms delay", ONDELAY.format(preset=500), 10, _response(490), None),
    ("behind a 20 s delay", ONDELAY.format(preset=20000), 10, NEVER_ON, None),
    ("behind a 40 s delay", ONDELAY.format(preset=40000), 10, NEVER_ON, None),
    # 100 runs, each a cycle that restarts the timer and counts and a stretch of idle
    # cycles: 200 steps at least; found by runs of held inputs up to the horizon the
    # presets give (no --depth)
    ("behind the 1 h timer demo", HOUR, 1000, HOUR_ENDS, None),
    ("the 1 h demo at 10 ms", HOUR, 10, HOUR_ENDS, None),
]


def run(props: Path, timeout: float, depth: int | None = None) -> tuple[float, float, str]:
    """Wall-clock and CPU seconds (the machine is shared: the CPU time is what the
    prover itself took), and the verdicts."""
    with tempfile.TemporaryDirectory() as out:
        start, cpu = time.perf_counter(), time.process_time()
        report = prove(props, out_dir=Path(out), timeout_s=timeout, depth=depth)
        seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    counts: dict[str, int] = {}
    for outcome in report.outcomes:
        verdict = outcome.verdict.value
        if outcome.trace is not None:
            verdict += f" (cycle {len(outcome.trace)})"
        counts[verdict] = counts.get(verdict, 0) + 1
    return seconds, cpu, ", ".join(f"{n} {v}" for v, n in counts.items())


def timed(timeout: float) -> None:
    """The properties behind timers, each file a property."""
    for name, program, cycle_ms, properties, depth in TIMED_CASES:
        with tempfile.TemporaryDirectory() as folder:
            (Path(folder) / "p.asi").write_text(program)
            props = Path(folder) / "p.props.toml"
            props.write_text(f"[master]\ncycle_ms = {cycle_ms}\n{properties}")
            seconds, cpu, verdicts = run(props, timeout, depth)
        print(f"{name:28} {seconds:6.2f} s {cpu:6.2f} s  {verdicts}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    which = parser.add_mutually_exclusive_group()
    which.add_argument("--demos-only", action="store_true")
    which.add_argument("--timers-only", action="store_true")
    parser.add_argument("--timeout", type=float, default=60.0,
                        help="seconds for each property (wall clock: generous on a shared machine)")
    args = parser.parse_args()
    total = total_cpu = 0.0
    print(f"{'':28} {'wall':>8} {'CPU':>8}")
    if not args.demos_only:
        timed(args.timeout)
    if args.timers_only:
        return
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
