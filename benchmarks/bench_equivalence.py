"""How long ``asictl diff OLD NEW --equivalent`` takes to prove a refactoring: one flag
renamed in programs of 60 to 300 lines, and a real change refuted.

The programs are the demos side by side (sequence, edge, timer, 1h_timer, oscil, logic,
flipflop, jump, ondelay, offdelay, pulse, again and again), each copy reading slave 1
and writing a slave of its own, its flags, timers, counters and labels renumbered, a
``BE`` that ended the demo's cycle made a jump to the copy's end; cut after the copy
that reaches the size. NEW is OLD with one flag of the first copy renamed (the
sequence's ``F 0.1``, ``F 1.1`` in the copy, to an unused ``F 120.5``), and a changed
NEW has one input of the first copy replaced. Each pair is decided by the same call as
``asictl diff --equivalent``, at 10 ms program cycles and the default time limit (30 s),
timed in wall-clock and CPU seconds. Usage:

    python3 benchmarks/bench_equivalence.py [--lines 60 150 300] [--timeout 30]
"""

from __future__ import annotations

import argparse
import re
import tempfile
import time
from pathlib import Path

from asictl.build import build_file
from asictl.prove.diff import equivalent

DEMOS = Path(__file__).resolve().parents[1] / "demos"
ORDER = ("sequence", "edge", "timer", "1h_timer", "oscil", "logic", "flipflop", "jump",
         "ondelay", "offdelay", "pulse")
_OPERAND = re.compile(r"\b(I2|I|Q|FY|FW|F|T|C)(\s+)(\d+)")


class _Numbers:
    """Fresh numbers for one copy: the demo's flag bytes, timers and counters mapped to
    ones no other copy uses."""

    def __init__(self) -> None:
        self.next = {"F": 1, "T": 0, "C": 0}

    def take(self, kind: str, mapping: dict[tuple[str, int], int], n: int) -> int:
        if (kind, n) not in mapping:
            mapping[(kind, n)] = self.next[kind]
            self.next[kind] += 1
        return mapping[(kind, n)]


def _copy(name: str, index: int, numbers: _Numbers) -> list[str]:
    """One demo's program lines, renumbered as copy ``index`` (output slave index + 2)."""
    text = (DEMOS / f"{name}.asi").read_text().split("[PROGRAM]\n", 1)[1]
    text = text.split("[END]")[0]
    mapping: dict[tuple[str, int], int] = {}
    out_slave = index + 2

    def operand(match: re.Match[str]) -> str:
        kind, space, n = match[1], match[2], int(match[3])
        if kind in ("I", "I2"):
            return f"{kind}{space}1"
        if kind == "Q":
            return f"Q{space}{out_slave}"
        if kind in ("F", "FY", "FW"):
            return f"{kind}{space}{numbers.take('F', mapping, n)}"
        return f"{kind}{space}{numbers.take(kind, mapping, n)}"

    lines = []
    ended = False
    labels = set(re.findall(r"^(\w+):", text, re.MULTILINE))
    for line in text.splitlines():
        code = line.split(";")[0].rstrip()
        if not code.strip():
            continue
        code = _OPERAND.sub(operand, code)
        for label in labels:
            code = re.sub(rf"\b{label}\b", f"{label}{index}", code)
        code, ends = re.subn(r"^(\w+:)?(\s+)BE$", rf"\1\2JU  = out{index}", code)
        ended = ended or bool(ends)
        lines.append(code)
    if not lines[-1].startswith("***"):
        lines.append("***")
    if ended:  # where the demo's cycle ended: the next copy
        flag = numbers.take("F", mapping, 1000)
        lines += [f"out{index}:  A   F {flag}.0", f"        =   F {flag}.0", "***"]
    return lines


def program(lines: int) -> str:
    """About ``lines`` lines of demos side by side (see the module's docstring)."""
    numbers = _Numbers()
    body: list[str] = []
    index = 0
    while len(body) < lines - 10:
        body += _copy(ORDER[index % len(ORDER)], index, numbers)
        index += 1
    setup = ["[SETUP]", "1: iiii, 0", *(f"{index + 2}: oooo, 0" for index in range(index))]
    return "\n".join([*setup, "[PROGRAM]", *body]) + "\n"


def _decide(old: str, new: str, timeout_s: float) -> tuple[str, int, float, float]:
    """The verdict, its depth, and the wall-clock and CPU seconds of the decision."""
    with tempfile.TemporaryDirectory() as folder:
        paths = [Path(folder) / "old.asi", Path(folder) / "new.asi"]
        for path, text in zip(paths, (old, new), strict=True):
            path.write_text(text)
        built = [build_file(path) for path in paths]
        for one in built:
            assert not one.has_errors, one.render()
        start, cpu = time.perf_counter(), time.process_time()
        result = equivalent(built[0], built[1], timeout_s=timeout_s, cycle_ms=10)
        return (result.verdict, result.cycles, time.perf_counter() - start,
                time.process_time() - cpu)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--lines", type=int, nargs="+", default=[60, 150, 300])
    parser.add_argument("--timeout", type=float, default=30.0)
    args = parser.parse_args()
    print("| lines | change | verdict | cycles | wall | CPU |\n|---|---|---|---|---|---|")
    for size in args.lines:
        old = program(size)
        assert "F 1.1" in old
        cases = {
            "one flag renamed": old.replace("F 1.1", "F 120.5"),
            "one input changed": old.replace("I 1.3", "I 1.1", 1),
        }
        for change, new in cases.items():
            verdict, depth, wall, cpu = _decide(old, new, args.timeout)
            print(f"| {len(old.splitlines())} | {change} | {verdict} | {depth} | "
                  f"{wall:.2f} s | {cpu:.2f} s |")


if __name__ == "__main__":
    main()
