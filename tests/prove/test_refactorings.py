"""Real refactorings of the demos are proved equivalent by matching the two programs'
state (a relational invariant, ``prove/correspond.py``), not by unrolling: the proof
holds at induction depth 0. Real changes are refuted with a scenario that passes on the
old program and fails on the new one under the simulator.

Each refactoring is an edit of a demo's text, checked to have changed the text, so a
demo rewritten later cannot turn a test into a comparison of a program with itself.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from replay import passes

from asictl.build import build_file
from asictl.cli import main
from asictl.il.loader import Program
from asictl.prove import equivalent
from asictl.prove.diff import readable

pytest.importorskip("z3")

DEMOS = Path(__file__).resolve().parents[2] / "demos"


def _demo(name: str) -> str:
    return (DEMOS / f"{name}.asi").read_text()


def _replace(text: str, *edits: tuple[str, str]) -> str:
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    return text


def _networks(text: str) -> tuple[str, list[str]]:
    head, body = text.split("[PROGRAM]\n", 1)
    return head + "[PROGRAM]\n", body.split("***\n")


def _swapped(text: str, i: int, j: int) -> str:
    """Networks i and j (from 0) exchanged."""
    head, parts = _networks(text)
    parts[i], parts[j] = parts[j], parts[i]
    return head + "***\n".join(parts)


def _composed() -> str:
    """A 60-line program: the demos sequence, edge and timer side by side, each on its
    own slaves and flags."""
    def body(name: str, *edits: tuple[str, str]) -> str:
        text = "***\n".join(_networks(_demo(name))[1])
        text = "\n".join(line for line in text.splitlines()
                         if line.strip() and not line.lstrip().startswith(";"))
        for old, new in edits:
            text = re.sub(old, new, text)
        return text.rstrip("*\n") + "\n***\n"

    setup = "".join(f"{n}: {'iiii' if n % 2 else 'oooo'}, 0\n" for n in range(1, 7))
    return ("[SETUP]\n" + setup + "[PROGRAM]\n" + body("sequence")
            + body("edge", (r"I 1\.", "I 3."), (r"Q 2\.", "Q 4."), (r"F 10\.", "F 20."),
                   (r"F(Y)? 11", r"F\1 21"), ("count", "count2"), ("show", "show2"))
            + body("timer", (r"I(2)? 1\.", r"I\1 5."), (r"Q 2\.", "Q 6."),
                   (r"F 0\.0", "F 30.0")))


REFACTORINGS = {
    "a flag renamed": ("sequence", lambda t: _replace(t, ("F 0.1", "F 7.3")), None),
    "two independent networks swapped": ("logic", lambda t: _swapped(t, 0, 2), None),
    "De Morgan of an AND": ("logic", lambda t: _replace(
        t, ("A   I 1.0           ; AND: a and b\n        A   I 1.1\n",
            "ON  I 1.0           ; not (not a or not b)\n        ON  I 1.1\n        N\n")),
        None),
    "a network split through a scratch flag": ("sequence", lambda t: _replace(
        t, ("        A   I 1.1\n        AN  F 0.1\n",
            "        A   I 1.1\n        =   F 9.0\n***\n        A   F 9.0\n        AN  F 0.1\n")),
        None),
    "labels renamed": ("edge", lambda t: _replace(t, ("count", "tally"), ("show", "display")),
                       None),
    "a timer renamed": ("timer", lambda t: _replace(t, ("T 6", "T 9")), 10.0),
    "a counter renamed": ("1h_timer", lambda t: _replace(t, ("C 7", "C 3")), 10.0),
}


def _program(path: Path) -> Program:
    built = build_file(path)
    assert not built.has_errors and built.program is not None, built.render()
    return built.program


@pytest.mark.parametrize("name", list(REFACTORINGS))
def test_a_refactoring_is_proved_equivalent_by_its_state_matched(tmp_path: Path, name: str):
    demo, edit, cycle_ms = REFACTORINGS[name]
    text = _demo(demo)
    edited = edit(text)
    assert edited != text
    (tmp_path / "old.asi").write_text(text)
    (tmp_path / "new.asi").write_text(edited)
    result = equivalent(_program(tmp_path / "old.asi"), _program(tmp_path / "new.asi"),
                        timeout_s=120, cycle_ms=cycle_ms)
    assert result.verdict == "equivalent", result.note
    assert result.cycles == 0  # proved by the matched state, nothing unrolled


def test_a_flag_renamed_in_an_80_line_program_is_proved_equivalent(tmp_path: Path):
    text = _composed()
    assert len(text.splitlines()) >= 60
    for flag, renamed in (("F 0.1", "F 40.3"), ("F 20.1", "F 41.6"), ("T 6", "T 12")):
        (tmp_path / "old.asi").write_text(text)
        (tmp_path / "new.asi").write_text(_replace(text, (flag, renamed)))
        result = equivalent(_program(tmp_path / "old.asi"), _program(tmp_path / "new.asi"),
                            timeout_s=120, cycle_ms=10)
        assert (result.verdict, result.cycles) == ("equivalent", 0), (flag, result.note)


CHANGES = {
    "another input acknowledges": ("sequence", ("A   I 1.3", "A   I 1.2"), "Q 2.1 (Conveyor)"),
    "an AND made an OR": ("logic", ("A   I 1.0           ; AND: a and b\n        A   I 1.1",
                                    "O   I 1.0\n        O   I 1.1"), "Q 2.0 (Both)"),
    "no edge, a level": ("edge", ("        AN  F 10.1\n        =   F 10.2",
                                  "        =   F 10.2"), "Q 2.1 (Odd)"),
    # 400 cycles of 10 ms before the two differ: beyond unrolling, found by the random
    # run of both programs, with the simulator's clock phase so that it replays
    "a timer 1 s shorter": ("timer", ("KT 5000", "KT 4000"), "Q 2.0 (Running)"),
}


@pytest.mark.parametrize("name", list(CHANGES))
def test_a_real_change_is_refuted_with_a_scenario_that_replays(tmp_path: Path, runner,
                                                                name: str):
    demo, (old_text, new_text), first = CHANGES[name]
    old, new = tmp_path / "old.asi", tmp_path / "new.asi"
    old.write_text(_demo(demo))
    new.write_text(_replace(_demo(demo), (old_text, new_text)))
    operand, symbol = first.rstrip(")").split(" (")
    (tmp_path / "new.symbols.toml").write_text(f'{symbol} = "{operand}"\n')
    result = runner.invoke(main, ["diff", str(old), str(new), "--equivalent",
                                  "--cycle-ms", "10"])
    assert result.exit_code == 1, result.output
    verdict = next(line for line in result.output.splitlines()
                   if line.startswith("different after cycle"))
    assert f": {first} is " in verdict, verdict
    scenario_path = tmp_path / "new.differs.scenario.toml"
    assert first in scenario_path.read_text()  # the first output that differs, by name
    assert passes(scenario_path, old, new) == {"old.asi": True, "new.asi": False}


def test_a_renamed_flag_the_host_can_read_is_a_difference(tmp_path: Path):
    """Equivalent means the same for whoever looks: a flag is the program's own unless
    the host writes it (``; asictl: host``) or the caller observes it, as mutation
    testing observes every flag, timer and counter (``readable``)."""
    text = _demo("sequence")
    (tmp_path / "old.asi").write_text(text)
    (tmp_path / "new.asi").write_text(_replace(text, ("F 0.1", "F 7.3")))
    old, new = _program(tmp_path / "old.asi"), _program(tmp_path / "new.asi")
    assert equivalent(old, new, timeout_s=120, cycle_ms=10).verdict == "equivalent"
    seen = equivalent(old, new, timeout_s=120, cycle_ms=10, observe=readable(old, new))
    assert seen.verdict == "different" and {"FY 0", "FY 7"} & set(seen.differences)
    host = "; asictl: host F 0.1\n"
    (tmp_path / "old.asi").write_text(host + text)
    (tmp_path / "new.asi").write_text(host + _replace(text, ("F 0.1", "F 7.3")))
    old, new = _program(tmp_path / "old.asi"), _program(tmp_path / "new.asi")
    assert equivalent(old, new, timeout_s=120, cycle_ms=10).verdict == "different"


def test_the_command_line_proves_a_rename_at_10_ms_within_the_default_limit(
        tmp_path: Path, runner):
    text = _demo("timer")
    (tmp_path / "old.asi").write_text(text)
    (tmp_path / "new.asi").write_text(_replace(text, ("F 0.0", "F 7.1"), ("T 6", "T 9")))
    result = runner.invoke(main, ["diff", str(tmp_path / "old.asi"), str(tmp_path / "new.asi"),
                                  "--equivalent", "--cycle-ms", "10"])
    assert result.exit_code == 0, result.output
    assert "equivalent: the same outputs for every input sequence (10 ms cycles" \
        in result.output
