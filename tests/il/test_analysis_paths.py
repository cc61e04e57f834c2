"""W711 and W715 against a brute-force oracle on generated control flow.

The analyses decide "can a cycle reach this?" and "can a cycle run this '=' after that
one?" with basic blocks and bit-set reachability. The oracle here walks the program's
lines one by one, from each line, with nothing in common with the analysis but the
language's rules for where a jump, BE, BEU and BEC lead.
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from asictl.il.checks import check_source
from asictl.source import from_string

HEAD = "[SETUP]\n1: iiii, 0\n2: oooo, 0\n[PROGRAM]\n"
FIRST = HEAD.count("\n") + 1
LABELS = ("up", "dn", "mid", "top")


@st.composite
def pieces(draw: st.DrawFn) -> list[str]:
    """Instructions that keep the register defined where it is read (no E213): each
    A starts a segment, so it loads the register whichever way a jump led there."""
    label = st.sampled_from(LABELS)
    kind = draw(st.sampled_from(["assign", "assign", "jc", "ju", "end", "beu", "bec", "label"]))
    if kind == "assign":
        return ["***", "    A I 1.0", f"    = Q 2.{draw(st.integers(0, 2))}"]
    if kind == "jc":
        return ["***", "    A I 1.1", f"    JC = {draw(label)}"]
    if kind == "ju":
        return [f"    JU = {draw(label)}"]
    if kind == "bec":
        return ["***", "    A I 1.2", "    BEC"]
    if kind == "label":
        return [f"{draw(label)}:"]
    return ["    BE" if kind == "end" else "    BEU"]


@st.composite
def programs(draw: st.DrawFn) -> list[str]:
    lines = [line for piece in draw(st.lists(pieces(), min_size=1, max_size=14))
             for line in piece]
    defined, seen = set(), []
    for line in lines:  # each label once
        if line.endswith(":") and line in defined:
            continue
        defined.add(line if line.endswith(":") else "")
        seen.append(line)
    used = {line.rsplit(" ", 1)[1] for line in seen if "= " in line and "J" in line}
    return seen + [f"{name}:" for name in sorted(used) if f"{name}:" not in defined] + ["    BE"]


def successors(lines: list[str], i: int) -> list[int]:
    text = lines[i].split()
    labels = {line[:-1]: n for n, line in enumerate(lines) if line.endswith(":")}
    after = [i + 1] if i + 1 < len(lines) else []
    if text[0] in ("JU", "JC"):
        return [labels[text[-1]]] + (after if text[0] == "JC" else [])
    if text[0] in ("BE", "BEU"):
        return []
    return after


def reaches(lines: list[str], start: int) -> set[int]:
    """Lines some path from ``start`` runs after it (``start`` too, if in a loop)."""
    seen: set[int] = set()
    work = successors(lines, start)
    while work:
        i = work.pop()
        if i not in seen:
            seen.add(i)
            work += successors(lines, i)
    return seen


@settings(max_examples=300, deadline=None)
@given(programs())
def test_assigned_twice_and_unreachable_agree_with_walking_every_path(lines: list[str]):
    diagnostics = check_source(from_string("p.asi", HEAD + "\n".join(lines) + "\n")).diagnostics
    assert not [d for d in diagnostics if d.is_error], diagnostics
    reachable = reaches(lines, 0) | {0}
    code = [i for i, line in enumerate(lines) if not line.endswith(":") and line != "***"]
    # W715: once per run of lines no path reaches, at its first instruction
    runs, in_run = [], False
    for i in range(len(lines)):
        if i in reachable:
            in_run = False
        elif i in code and not in_run:
            runs.append(i)
            in_run = True
    unreachable = sorted(d.span.line - FIRST for d in diagnostics if d.code == "W715")
    assert unreachable == runs

    assigns = {i: lines[i].split()[-1] for i in code if lines[i].startswith("    =")
               and i in reachable}
    later = {b for a in assigns for b in reaches(lines, a)
             if b in assigns and b != a and assigns[b] == assigns[a]}
    reported = [d for d in diagnostics if d.code == "W711"]
    pairs = {(d.related[0][0].line - FIRST, d.span.line - FIRST) for d in reported}
    for a, b in pairs:  # every report is a real pair: a path runs b after a
        assert assigns[a] == assigns[b] and b in reaches(lines, a)
    covered = {i for pair in pairs for i in pair}
    assert later <= covered  # and every assignment that may overwrite another is named
