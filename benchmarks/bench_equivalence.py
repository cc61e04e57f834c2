"""How long ``asictl diff OLD NEW --equivalent`` takes to prove refactorings in
programs of 60 to 300 lines, and to refute real changes.

The programs are the demos side by side (1h_timer, timer, pulse, sequence, edge, oscil,
logic, flipflop, jump, ondelay, offdelay, again and again), each copy reading slave 1
and writing a slave of its own, its flags, timers, counters and labels renumbered, a
``BE`` that ended the demo's cycle made a jump to the copy's end; cut after the copy
that reaches the size. So every program begins with the 1 h timer (timer 0, counter 0),
the 5 s timer (timer 1, flag 1.0) and the pulse (timer 2). NEW is OLD with one
refactoring of those first copies (``refactorings``): a flag, a timer or a counter
renamed, the pulse's network moved ahead of the 5 s timer's, De Morgan on the 5 s
timer's start, that network split in two through a new scratch flag, the 1 h timer's
labels renamed. Before it is timed, each refactoring is run through the simulator
beside OLD on random inputs (``--runs`` runs of 30 s, inputs held for one cycle to 6 s),
and the benchmark stops if any output differs. The real changes (``changes``): the 5 s
timer started by another input, and its run-out check moved ahead of its start, which
reads the timer before this cycle's start and differs only when the input rises in the
cycle after the timer ran out (501 cycles in; the random simulator runs do not see it).
Each pair is decided by the same call as ``asictl diff --equivalent``, at 10 ms program
cycles and the default time limit (30 s), timed in wall-clock and CPU seconds. Usage:

    python3 benchmarks/bench_equivalence.py [--lines 60 150 290] [--timeout 30] [--runs 3]
"""

from __future__ import annotations

import argparse
import random
import re
import tempfile
import time
from pathlib import Path

from asictl.build import build_file
from asictl.prove.diff import equivalent
from asictl.sim.engine import Simulation, variables_of
from asictl.sim.scenario import load_scenario

DEMOS = Path(__file__).resolve().parents[1] / "demos"
ORDER = ("1h_timer", "timer", "pulse", "sequence", "edge", "oscil", "logic", "flipflop",
         "jump", "ondelay", "offdelay")
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


def _networks(text: str) -> tuple[str, list[str]]:
    """The text up to [PROGRAM] and the networks after it (each up to its ``***``)."""
    head, body = text.split("[PROGRAM]\n", 1)
    return head + "[PROGRAM]\n", body.split("***\n")


def _first(networks: list[str], line: str) -> int:
    """The first network that holds ``line``."""
    return next(n for n, network in enumerate(networks) if line in network)


def _edit_network(text: str, line: str, *edits: tuple[str, str]) -> str:
    """The first network holding ``line`` with ``edits`` (each must apply)."""
    head, networks = _networks(text)
    n = _first(networks, line)
    for old, new in edits:
        assert old in networks[n], (old, networks[n])
        networks[n] = networks[n].replace(old, new)
    return head + "***\n".join(networks)


def _moved_ahead(text: str, moved: str, ahead_of: str) -> str:
    """The first network holding ``moved`` taken out and put in front of the first one
    holding ``ahead_of``."""
    head, networks = _networks(text)
    network = networks.pop(_first(networks, moved))
    networks.insert(_first(networks, ahead_of), network)
    return head + "***\n".join(networks)


def _renamed(text: str, *names: tuple[str, str]) -> str:
    """Whole words renamed (``T 1`` but not ``T 10``); each must occur."""
    for old, new in names:
        text, count = re.subn(rf"\b{re.escape(old)}\b(?!\.)", new, text)
        assert count, old
    return text


#: The first copies of a program: the 1 h timer (timer 0, counter 0, labels start0,
#: next0 and show0), the 5 s timer (timer 1, flag 1.0) and the pulse (timer 2).
_TIMER = "L   KT 5000"
_PULSE = "L   KT 1000"


def refactorings(old: str) -> dict[str, str]:
    """Edits of the first copies that keep the behaviour (each checked by ``_simulated``
    before it is timed), by kind."""
    return {
        "one flag renamed": old.replace("F 1.0", "F 120.5"),
        "a network moved ahead of a timer network": _moved_ahead(old, _PULSE, _TIMER),
        "a timer renamed": _renamed(old, ("T 1", "T 14")),
        "a counter renamed": _renamed(old, ("C 0", "C 14")),
        "De Morgan on one network": _edit_network(
            old, _TIMER, ("A   I 1.0\n        AN  I2 1.0\n",
                          "ON  I 1.0\n        O   I2 1.0\n        N\n")),
        "a network split in two": _edit_network(
            old, _TIMER, ("        L   KT 5000\n        A   I 1.0\n        AN  I2 1.0\n",
                          "        A   I 1.0\n        AN  I2 1.0\n        =   F 121.0\n"
                          "***\n        L   KT 5000\n        A   F 121.0\n")),
        "labels renamed": _renamed(old, ("start0", "begin0"), ("next0", "again0"),
                                   ("show0", "display0")),
    }


def changes(old: str) -> dict[str, str]:
    """Real changes: the 5 s timer started by another input, and its run-out check
    (the network that sets ``Q 3.1``) moved ahead of its start."""
    return {
        "one input changed": _edit_network(old, _TIMER, ("A   I 1.0", "A   I 1.2")),
        "the run-out check moved ahead of its timer's start": _moved_ahead(
            old, "S   Q 3.1", _TIMER),
    }


def _outputs(text: str, scenario: str) -> dict[str, list[tuple[float, int]]]:
    """Each output bit's changes when the simulator runs ``text`` through ``scenario``."""
    with tempfile.TemporaryDirectory() as folder:
        program, steps = Path(folder) / "p.asi", Path(folder) / "s.toml"
        program.write_text(text)
        steps.write_text(scenario)
        built = build_file(program)
        assert built.image is not None, built.render()
        result = Simulation(built, load_scenario(steps, variables_of(built.image.pmap)),
                            trace=True).run()
    assert result.trace is not None
    return {signal.name: signal.changes for signal in result.trace.signals
            if signal.name.startswith("Q ")}


def _random_inputs(seed: int, seconds: float) -> str:
    """A scenario of random inputs on slave 1 at 10 ms cycles, each held for one cycle
    to 6 s (so that the 5 s timer runs out now and then)."""
    rng = random.Random(seed)
    steps, at = [], 0
    while at < seconds * 1000:
        steps.append(f'[[step]]\nat_ms = {at}\nset = {{ "IB 0" = {rng.randrange(16) << 4} }}\n')
        at += rng.choice((10, 10, 20, 30, 50, 100, 500, 2000, 6000))
    return "[master]\ncycle_ms = 10\n" + "".join(steps)


def _simulated(old: str, new: str, runs: int) -> bool:
    """Whether the simulator gives both programs the same outputs at the same times on
    ``runs`` random input runs of 30 s: a check that a refactoring keeps the behaviour
    before the prover is timed on it (no proof: a difference behind the 1 h timer is
    out of its reach)."""
    for seed in range(runs):
        scenario = _random_inputs(seed, 30.0)
        if _outputs(old, scenario) != _outputs(new, scenario):
            return False
    return True


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
    parser.add_argument("--lines", type=int, nargs="+", default=[60, 150, 290])
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("--runs", type=int, default=3,
                        help="random simulator runs that check each refactoring first")
    parser.add_argument("--only", help="only the cases whose name holds this text")
    args = parser.parse_args()
    print("| lines | change | verdict | cycles | wall | CPU |\n|---|---|---|---|---|---|")
    for size in args.lines:
        old = program(size)
        cases = refactorings(old)
        for change, new in cases.items():
            assert new != old, change
            assert _simulated(old, new, args.runs), f"{change}: the simulator tells them apart"
        cases.update(changes(old))
        for change, new in cases.items():
            if args.only and args.only not in change:
                continue
            verdict, depth, wall, cpu = _decide(old, new, args.timeout)
            print(f"| {len(old.splitlines())} | {change} | {verdict} | {depth} | "
                  f"{wall:.2f} s | {cpu:.2f} s |", flush=True)


if __name__ == "__main__":
    main()
