"""Refactorings of a program of several demos side by side, each kind proved equivalent,
and a subtly wrong version of each found different, with a scenario the simulator
replays (passes on the old program, fails on the new).

The program: edge, timer (5 s), 1h_timer (a 36 s timer and a counter) and pulse, each
writing its own output slave, all reading slave 1. Every refactoring here keeps the
behaviour (the reason is given with each); every wrong version changes it, most of them
in the first cycle, one only when an input edge comes in the very cycle the 5 s timer
has run out: a random run of both programs does not see that, and a difference 501
cycles deep is out of reach of unrolling, so it is found with steps of idle cycles.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from replay import passes

from asictl.build import build, build_file
from asictl.cli import main
from asictl.il.loader import Program
from asictl.observe.condition import Truth
from asictl.prove import equivalent
from asictl.prove.engine import Machine, Setup
from asictl.prove.props import Kind, Property
from asictl.prove.symbolic import Key, build_cycle, product
from asictl.source import from_string

pytest.importorskip("z3")

DEMOS = Path(__file__).resolve().parents[2] / "demos"


def _body(name: str, *renames: tuple[str, str]) -> list[str]:
    """A demo's networks without comments, with whole words renamed."""
    text = (DEMOS / f"{name}.asi").read_text().split("[PROGRAM]\n", 1)[1]
    lines = [line.split(";")[0].rstrip() for line in text.splitlines()]
    code = "\n".join(line for line in lines if line.strip())
    for old, new in renames:
        code = re.sub(rf"\b{old}\b", new, code)
    return code.rstrip("*\n").split("\n***\n")


def _program(networks: list[str]) -> str:
    setup = "[SETUP]\n1: iiii, 0\n" + "".join(f"{n}: oooo, 0\n" for n in range(2, 6))
    return setup + "[PROGRAM]\n" + "\n***\n".join(networks) + "\n***\n"


NETWORKS = [
    *_body("edge"),
    *_body("timer", (r"Q 2", "Q 3")),
    *_body("1h_timer", (r"Q 2", "Q 4"), ("start", "hstart"), ("next", "hnext"),
           ("show", "hshow")),
    *_body("pulse", (r"Q 2", "Q 5")),
]
OLD = _program(NETWORKS)
#: the networks by what they do
START = next(n for n, net in enumerate(NETWORKS) if "KT 5000" in net)
RUNNING, RAN_OUT = START + 1, START + 2
PULSE = next(n for n, net in enumerate(NETWORKS) if "KT 1000" in net)
SHOW = next(n for n, net in enumerate(NETWORKS) if net.startswith("show:"))


def _moved(networks: list[str], moved: int, ahead_of: int) -> list[str]:
    """Network ``moved`` put in front of network ``ahead_of``."""
    result = list(networks)
    network = result.pop(moved)
    result.insert(ahead_of if ahead_of < moved else ahead_of - 1, network)
    return result


def _edited(index: int, old: str, new: str) -> str:
    assert old in NETWORKS[index], (old, NETWORKS[index])
    networks = list(NETWORKS)
    networks[index] = networks[index].replace(old, new)
    return _program(networks)


def _renamed(text: str, old: str, new: str, *, keep: int = 0) -> str:
    """Every use of ``old`` renamed but the ``keep``-th (from 1; 0: none kept)."""
    count = 0

    def rename(match: re.Match[str]) -> str:
        nonlocal count
        count += 1
        return match[0] if count == keep else new

    renamed = re.sub(rf"\b{re.escape(old)}\b(?!\.)", rename, text)
    assert count >= keep and count - (keep > 0) > 0, old  # the kept use, and others
    return renamed


EDGE_START = "        A   I 1.0\n        AN  I2 1.0\n"
REFACTORINGS = {
    # the pulse's network touches nothing the 5 s timer's networks read or write but
    # the constant register, which each of them loads before it starts its timer
    "a network moved ahead of a timer network": _program(_moved(NETWORKS, PULSE, START)),
    # the timer is started only on a rising edge of I 1.0, which is when the edge's
    # counting branch runs: proved with the edge's memory paired with the input
    "a timer network moved into the branch of its edge": _program(
        _moved(NETWORKS, START, SHOW)),
    "a timer renamed": _renamed(OLD, "T 6", "T 14"),
    "a counter renamed": _renamed(OLD, "C 7", "C 14"),
    "De Morgan on one network": _edited(START, EDGE_START,
                                        "        ON  I 1.0\n        O   I2 1.0\n        N\n"),
    "a network split in two through a scratch flag": _edited(
        START, "        L   KT 5000\n" + EDGE_START,
        EDGE_START + "        =   F 50.0\n***\n        L   KT 5000\n        A   F 50.0\n"),
    "labels renamed": _renamed(_renamed(OLD, "hstart", "begin"), "hnext", "again"),
}

WRONG = {
    # the run-out check now reads the timer before this cycle's start: an edge in the
    # cycle the timer has run out restarts it, and the old program never sees it ran out
    "a network moved ahead of the one that writes what it reads": _program(
        _moved(NETWORKS, RAN_OUT, START)),
    "a network moved ahead of the timer it shows": _program(
        _moved(NETWORKS, RUNNING, START)),
    "a timer renamed but one use": _renamed(OLD, "T 6", "T 14", keep=2),
    "a counter renamed but one use": _renamed(OLD, "C 7", "C 14", keep=6),
    "De Morgan without the N": _edited(START, EDGE_START,
                                       "        ON  I 1.0\n        O   I2 1.0\n"),
    # the second half reads the scratch flag before the first half writes it: a cycle
    # late
    "a network split with its halves the wrong way round": _edited(
        START, NETWORKS[START],
        "        L   KT 5000\n        A   F 50.0\n        S   T 6\n        S   F 0.0\n***\n"
        + EDGE_START + "        =   F 50.0"),
    "a jump sent to another label": _renamed(OLD, "hstart", "hnext", keep=2),
}


def _decide(tmp_path: Path, new: str):
    (tmp_path / "old.asi").write_text(OLD)
    (tmp_path / "new.asi").write_text(new)
    programs: list[Program] = []
    for name in ("old.asi", "new.asi"):
        built = build_file(tmp_path / name)
        assert not built.has_errors and built.program is not None, built.render()
        programs.append(built.program)
    return equivalent(programs[0], programs[1], timeout_s=60, cycle_ms=10)


def test_the_program_is_what_the_cases_edit():
    assert len(OLD.splitlines()) >= 60
    assert NETWORKS[START].startswith("        L   KT 5000")
    assert "S   Q 3.1" in NETWORKS[RAN_OUT] and "=   Q 3.0" in NETWORKS[RUNNING]
    assert "JU  = show" in NETWORKS[SHOW - 2]  # the branch a network before show joins
    for name, new in {**REFACTORINGS, **WRONG}.items():
        assert new != OLD, name


@pytest.mark.parametrize("name", list(REFACTORINGS))
def test_a_refactoring_is_proved_equivalent(tmp_path: Path, name: str):
    result = _decide(tmp_path, REFACTORINGS[name])
    assert (result.verdict, result.cycles) == ("equivalent", 0), result.note


#: the one wrong version whose difference lies behind the timer: the input rises in the
#: cycle after the 5 s timer ran out
BEHIND_THE_TIMER = "different after cycle 501: Q 3.1 is 0 in old.asi, 1 in new.asi"


@pytest.mark.parametrize("name", list(WRONG))
def test_a_wrong_refactoring_is_different_with_a_scenario_that_replays(
        tmp_path: Path, runner, name: str):
    old, new = tmp_path / "old.asi", tmp_path / "new.asi"
    old.write_text(OLD)
    new.write_text(WRONG[name])
    result = runner.invoke(main, ["diff", str(old), str(new), "--equivalent",
                                  "--cycle-ms", "10", "--timeout", "2min"])
    assert result.exit_code == 1, result.output
    assert "different after cycle " in result.output
    if name == "a network moved ahead of the one that writes what it reads":
        assert BEHIND_THE_TIMER in result.output
    assert passes(tmp_path / "new.differs.scenario.toml", old, new) == {
        "old.asi": True, "new.asi": False}


def _machine(second_text: str, observed: list[Key]) -> Machine:
    """The two programs side by side as ``equivalent`` builds them, ``observed`` the
    cells compared."""
    programs = []
    for text in (OLD, second_text):
        built = build(from_string("p.asi", text))
        assert not built.has_errors and built.program is not None, built.render()
        programs.append(built.program)
    slaves = (1, 2, 3, 4, 5)
    cycles = [build_cycle(program, slaves=slaves, cycle_us=10_000, watch=observed,
                          prefix=f"{side}.")
              for side, program in zip(("a", "b"), programs, strict=True)]
    return Machine(programs[0], Setup(slaves, 10_000), [], [],
                   prebuilt=product(*cycles),
                   observed=[(("a", *cell), ("b", *cell)) for cell in observed],
                   second=programs[1])


@pytest.mark.parametrize(("reads", "observed", "steps"), [
    ("", [("Q", 1)], True),
    # the second program loads the 5 s timer's word: what a cycle sees of it changes
    # with every tick, so no stretch of cycles is idle
    ("***\n        L   T 6\n        T   FY 60\n", [("Q", 1)], False),
    # the timer's word is compared (mutation testing compares every timer)
    ("", [("Q", 1), ("T", 6)], False),
])
def test_two_programs_are_searched_in_idle_steps_only_if_no_timer_word_is_read(
        reads: str, observed: list[Key], steps: bool):
    machine = _machine(WRONG["a network moved ahead of the one that writes what it reads"]
                       + reads, observed)
    same = Property("same outputs", Kind.ALWAYS, Truth(True), 0)
    assert machine.jumps_possible(same) is steps
