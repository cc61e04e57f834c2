"""A witness or counterexample that depends on the 10 ms clock says the phase it assumes
(``first_tick_ms``, the time from time 0 to the first tick): the one ``asictl sim`` has
for that program and master where the shortest allows, or another, which its note names;
replayed, it reproduces tick for tick on the phase it names: a witness passes, a
counterexample fails at its last step. One about no timer says that any phase does."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from replay import assert_replays

from asictl.build import build_file
from asictl.cli import main
from asictl.prove.engine import Verdict
from asictl.prove.props import read_properties
from asictl.prove.session import prove as prove_file
from asictl.prove.session import setup_of
from asictl.source import read_source

pytest.importorskip("z3")

#: T 1 runs 50 ms from I 1.0: what it has left after a cycle depends on how many ticks
#: fell between the cycles, so on the clock's phase. Q 4.1 (another output byte than
#: Q 2.0's) follows I 1.1 alone.
PROGRAM = """[SETUP]
1: iiii, 0
2: oooo, 0
4: oooo, 0

[PROGRAM]
        L   KT 50
        A   I 1.0
        S   T 1
        A   T 1
        =   Q 2.0
***
        A   I 1.1
        =   Q 4.1
***
"""

PROPS = """[master]
cycle_ms = {cycle}
[[property]]
name = "twenty left"
reachable = "TV 1 == 20"
[[property]]
name = "never ten left"
never = "TV 1 == 10"
[[property]]
name = "the timer runs"
reachable = "Q 2.0"
[[property]]
name = "the lamp"
never = "Q 4.1"
"""


@pytest.mark.parametrize("cycle", [3, 7, 15])
def test_a_witness_replays_on_the_phase_it_says(tmp_path: Path, cycle: int):
    (tmp_path / "p.asi").write_text(PROGRAM)
    props = tmp_path / "p.props.toml"
    props.write_text(PROPS.format(cycle=cycle))
    report = prove_file(props, timeout_s=300.0)
    built = build_file(tmp_path / "p.asi")
    assert built.image is not None
    setup, _ = setup_of(read_properties(read_source(props)), built)
    assert setup.phase_us is not None
    replayed = simulators = 0
    for outcome in report.outcomes:
        if outcome.verdict not in (Verdict.REFUTED, Verdict.REACHED):
            continue
        path = report.written[outcome.prop.name]
        text = path.read_text()
        said = re.findall(r"^first_tick_ms = (.*)$", text, re.MULTILINE)
        if outcome.prop.name == "the lamp":  # no timer: any phase
            assert outcome.phase_us is None and not said
            assert "# phase: any" in text
            continue
        assert outcome.phase_us is not None and said == [f"{outcome.phase_us / 1000:g}"]
        if outcome.phase_us == setup.phase_us:
            assert "found only" not in outcome.note, outcome.note
            simulators += 1
        else:  # the shortest needs another phase: the note says which
            assert f"found only with the first 10 ms tick {said[0]} ms after time 0" \
                in outcome.note
    for outcome in report.outcomes:  # the lamp's too
        if outcome.verdict in (Verdict.REFUTED, Verdict.REACHED):
            assert_replays(tmp_path / "p.asi", report.written[outcome.prop.name],
                           outcome.verdict)
            replayed += 1
    assert replayed >= 3 and simulators >= 1


@pytest.mark.parametrize("cycle", [3, 7, 15])
def test_a_witness_for_any_phase_replays_on_the_phase_it_names(
        tmp_path: Path, cycle: int, monkeypatch: pytest.MonkeyPatch):
    """Without the simulator's phase to prefer, the solver picks any: the scenario's
    first_tick_ms moves the simulator's clock there, and it replays all the same."""
    import asictl.prove.session as session

    monkeypatch.setattr(session, "simulator_phase", lambda *_: None)
    (tmp_path / "p.asi").write_text(PROGRAM)
    props = tmp_path / "p.props.toml"
    props.write_text(PROPS.format(cycle=cycle))
    report = prove_file(props, timeout_s=300.0)
    phases = set()
    for outcome in report.outcomes:
        if outcome.verdict in (Verdict.REFUTED, Verdict.REACHED):
            phases.add(outcome.phase_us)
            assert_replays(tmp_path / "p.asi", report.written[outcome.prop.name],
                           outcome.verdict)
    assert len(phases) >= 2  # the clock's phase and none, at the least


def test_a_difference_that_rests_on_the_clock_replays_on_its_phase(tmp_path: Path, runner):
    """Two programs whose timers differ by one tick: the scenario that tells them apart
    names the phase it needs, and replays on it (passes on the old, fails on the new at
    its last step), whatever phase the solver picked."""
    old = tmp_path / "old.asi"
    new = tmp_path / "new.asi"
    running = PROGRAM.replace("S   T 1\n", "S   T 1\n***\n")  # Q 2.0 = T 1 running
    old.write_text(running)
    new.write_text(running.replace("KT 50", "KT 60"))
    for cycle in ("3", "7", "15"):
        scenario = tmp_path / f"differs.{cycle}.scenario.toml"
        result = runner.invoke(main, ["diff", str(old), str(new), "--equivalent",
                                      "--cycle-ms", cycle, "--scenario", str(scenario)])
        assert result.exit_code == 1, result.output
        assert re.search(r"^first_tick_ms = [0-9.]+$", scenario.read_text(), re.MULTILINE)
        assert_replays(old, scenario, Verdict.REACHED)  # passes on the old
        assert_replays(new, scenario, Verdict.REFUTED)  # fails at its last step on the new
