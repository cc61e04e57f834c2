"""STEP 5 habits that IL reads differently (W205-W208): each warned at its line, none
on the program written the way asictl reads it, and each silenced like any warning."""

from __future__ import annotations

import pytest

from asictl.build import check
from asictl.source import from_string

SETUP = "[SETUP]\n1: iiii, 0\n2: oooo, 0\n[PROGRAM]\n"  # the program starts at line 5


def found(body: str) -> list[tuple[str, int]]:
    built = check(from_string("t.asi", SETUP + body))
    return [(d.code, d.span.line) for d in built.diagnostics if d.span and d.code[0] == "W"]


def lines(*rows: str) -> str:
    return "".join(f"{row}\n" for row in rows)


TRAPS = {
    "W205": (  # JC did not jump: the register is 0, A I 1.1 always 0
        lines("    A I 1.0", "    JC = x", "    A I 1.1", "    = Q 2.0", "x:  BE"), 7,
        lines("    A I 1.0", "    JC = x", "    ***", "    A I 1.1", "    = Q 2.0", "x:  BE"),
    ),
    "W206": (  # T right after L KT stores the older ACCU1
        lines("    L KT 500", "    T FY 10", "    A I 1.0", "    = Q 2.0"), 6,
        lines("    L KB 50", "    T FY 10", "    A I 1.0", "    = Q 2.0"),
    ),
    "W207": (  # the JU leaves a segment start; at x: O combines with an undefined register
        lines("    A I 1.0", "    JC = y", "    ***", "    JU = x", "y:  A I 1.2",
              "x:  O I 1.3", "    = Q 2.0"), 10,
        lines("    A I 1.0", "    JC = y", "    ***", "    JU = x", "y:  A I 1.2",
              "    ***", "x:  O I 1.3", "    = Q 2.0"),
    ),
    "W208": (  # waits for an input inside one cycle: certain cycle time-out once it jumps
        lines("wait: A I 1.0", "    JC = wait", "    ***", "    A I 1.1", "    = Q 2.0"), 6,
        lines("    A I 1.0", "    JC = done", "    ***", "    A I 1.1", "    = Q 2.0",
              "done: BE"),
    ),
}


@pytest.mark.parametrize("code", sorted(TRAPS))
def test_each_trap_is_warned_at_its_line(code: str):
    trap, line, _ = TRAPS[code]
    assert (code, line) in found(trap)
    assert [c for c, _ in found(trap) if c.startswith("W20")] == [code]


@pytest.mark.parametrize("code", sorted(TRAPS))
def test_the_program_written_as_asictl_reads_it_gets_no_warning(code: str):
    _, _, fixed = TRAPS[code]
    assert [c for c, _ in found(fixed) if c.startswith("W20")] == []


@pytest.mark.parametrize("code", sorted(TRAPS))
def test_each_trap_is_silenced_by_a_directive(code: str):
    trap, line, _ = TRAPS[code]
    rows = trap.split("\n")
    rows[line - 5] += f" ; asictl: ignore {code}"
    assert code not in [c for c, _ in found("\n".join(rows))]


def test_a_jc_and_a_bec_that_did_not_act_both_leave_zero():
    body = lines("    A I 1.0", "    BEC", "    O I 1.1", "    = Q 2.0")
    assert found(body) == []  # 0 or x is x: O is fine
    body = lines("    A I 1.0", "    BEC", "    AN I 1.1", "    = Q 2.0")
    assert found(body) == [("W205", 7)]


def test_a_loop_that_can_end_is_no_trap():
    flag = lines("wait: A F 10.0", "    JC = wait", "    ***", "    A I 1.1",
                 "    = Q 2.0")  # a flag the host may write
    exits = lines("wait: A I 1.0", "    JC = out", "    ***", "    A I 1.1", "    JC = wait",
                  "out: A I 1.2", "    = Q 2.0")  # jumps out of the loop
    compare = lines("wait: L FY 1", "    L KB 3", "    != F", "    JC = wait", "    ***",
                    "    A I 1.1", "    = Q 2.0")
    for body in (flag, exits, compare):
        assert "W208" not in [c for c, _ in found(body)], body


def test_an_unconditional_loop_back_without_a_way_out():
    body = lines("    A I 1.0", "    = Q 2.0", "back: L FY 1", "    T FY 2", "    JU = back")
    assert ("W208", 9) in found(body)


def test_the_traps_are_documented():
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[2] / "docs" / "language.md").read_text()
    for code in TRAPS:
        assert f"| {code} | warning |" in doc
