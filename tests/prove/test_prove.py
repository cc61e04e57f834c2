"""``asictl prove`` on programs whose answers are known, and every counterexample it
writes replayed with the simulator: a refuted property's scenario must fail at its last
step, a reached one's must pass."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from asictl.build import build_file
from asictl.cli import main
from asictl.prove.engine import Verdict
from asictl.prove.session import Invalid, Report
from asictl.prove.session import prove as prove_file
from asictl.sim.engine import Simulation, variables_of
from asictl.sim.scenario import load_scenario

SETUP = "[SETUP]\n1: iiii, 0\n2: oooo, 0\n"

#: The two directions of a motor: each only while the other is off (the interlock).
REVERSE = SETUP + """[PROGRAM]
        A   I 1.0       ; forward
        AN  I 1.2       ; stop
        AN  Q 2.1
        =   Q 2.0
***
        A   I 1.1       ; backward
        AN  I 1.2
        AN  Q 2.0
        =   Q 2.1
***
"""

#: The same, but each direction looks at the other's *previous* output: a race.
RACE = SETUP + """[PROGRAM]
        A   I 1.0
        AN  I 1.2
        AN  F 10.1      ; what Q 2.1 was in the previous cycle
        =   Q 2.0
***
        A   I 1.1
        AN  I 1.2
        AN  F 10.0
        =   Q 2.1
***
        A   Q 2.0
        =   F 10.0
***
        A   Q 2.1
        =   F 10.1
***
"""

EXCLUSION = """
[[property]]
name = "never both directions"
never = "Q 2.0 and Q 2.1"
"""
STOP = """
[[property]]
name = "stop wins"
always = "not I 1.2 or not (Q 2.0 or Q 2.1)"
"""
INTERLOCK = EXCLUSION + STOP

#: A latch the stop resets only for one direction.
BAD_STOP = SETUP + """[PROGRAM]
        A   I 1.0
        S   Q 2.0
        A   I 1.1
        S   Q 2.1
        A   I 1.2
        R   Q 2.0
***
"""

#: On-delay: Q 2.0 on 2 s after I 1.0 came on.
ONDELAY = SETUP + """[PROGRAM]
        L   KT 2000
        A   I 1.0
        AN  I2 1.0
        S   T 2
***
        AN  I 1.0
        R   T 2
***
        A   I 1.0
        AN  T 2
        =   Q 2.0
***
"""

#: Counts rising edges of I 1.0 up to 3, then starts again.
COUNT3 = SETUP + """[PROGRAM]
        A   I 1.0
        AN  I2 1.0
        CU  C 1
***
        L   C 1
        L   KB 3
        >=  F
        R   C 1
***
        A   C 1
        =   Q 2.0
***
"""

#: Two flags toggled together on every rising edge: F 10.0 and F 10.1 are always
#: equal, so Q 2.0 (one without the other) is never on; that needs the equality as an
#: invariant, which k-induction on Q 2.0 alone never finds.
LOCKSTEP = SETUP + """[PROGRAM]
        A   I 1.0       ; the rising edge
        AN  I2 1.0
        =   F 30.0
***
        A   F 30.0      ; each flag toggles on it
        A   F 10.0
        =   F 20.0
***
        A   F 30.0
        AN  F 10.0
        =   F 20.1
***
        A   F 20.1
        S   F 10.0
***
        A   F 20.0
        R   F 10.0
***
        A   F 30.0
        A   F 10.1
        =   F 21.0
***
        A   F 30.0
        AN  F 10.1
        =   F 21.1
***
        A   F 21.1
        S   F 10.1
***
        A   F 21.0
        R   F 10.1
***
        A   F 10.0      ; one without the other
        AN  F 10.1
        =   Q 2.0
***
"""


def prove(props: Path, **options: object) -> Report:
    """``prove`` with a time limit no load on the machine reaches: verdicts, not timing."""
    options.setdefault("timeout_s", 300.0)
    return prove_file(props, **options)  # type: ignore[arg-type]


def _files(tmp_path: Path, program: str, properties: str, name: str = "p") -> Path:
    (tmp_path / f"{name}.asi").write_text(program)
    props = tmp_path / f"{name}.props.toml"
    props.write_text(properties)
    return props


def _verdicts(report: Report) -> dict[str, Verdict]:
    return {o.prop.name: o.verdict for o in report.outcomes}


def _replay(report: Report) -> None:
    """Each written scenario under the simulator: refuted ones fail at their last step
    (and only there), reached ones pass."""
    for outcome in report.outcomes:
        path = report.written.get(outcome.prop.name)
        if outcome.verdict not in (Verdict.REFUTED, Verdict.REACHED):
            assert path is None
            continue
        assert path is not None and path.is_file()
        built = build_file(report.program)
        assert built.image is not None
        scenario = load_scenario(path, variables_of(built.image.pmap))
        result = Simulation(built, scenario).run()
        last = max(step.at_ms for step in scenario.steps)
        if outcome.verdict is Verdict.REFUTED:
            assert result.failures, f"{path} passes under the simulator"
            assert {f.at_ms for f in result.failures} == {last}
        else:
            assert result.passed, f"{path}: {[str(f) for f in result.failures]}"


def test_mutual_exclusion_holds_and_the_stop_wins(tmp_path: Path):
    report = prove(_files(tmp_path, REVERSE, "[master]\ncycle_ms = 5\n" + INTERLOCK))
    assert _verdicts(report) == {"never both directions": Verdict.PROVED,
                                 "stop wins": Verdict.PROVED}
    assert report.passed and not report.written


def test_a_race_breaks_mutual_exclusion_and_the_counterexample_replays(tmp_path: Path):
    report = prove(_files(tmp_path, RACE, "[master]\ncycle_ms = 5\n" + INTERLOCK))
    verdicts = _verdicts(report)
    assert verdicts["never both directions"] is Verdict.REFUTED
    assert verdicts["stop wins"] is Verdict.PROVED
    written = report.written["never both directions"]
    assert written.name == "p.cex.never-both-directions.scenario.toml"
    _replay(report)


def test_an_environment_assumption_rules_the_race_out(tmp_path: Path):
    assume = '[master]\ncycle_ms = 5\n[assume]\nalways = ["not (I 1.0 and I 1.1)"]\n'
    report = prove(_files(tmp_path, RACE, assume + EXCLUSION))
    # each direction needs its own input in the same cycle
    assert _verdicts(report)["never both directions"] is Verdict.PROVED


def test_an_emergency_stop_that_misses_one_direction_is_refuted(tmp_path: Path):
    report = prove(_files(tmp_path, BAD_STOP, "[master]\ncycle_ms = 10\n" + STOP))
    assert _verdicts(report) == {"stop wins": Verdict.REFUTED}
    _replay(report)


def test_a_timer_too_slow_for_the_response_and_one_fast_enough(tmp_path: Path):
    props = """[master]
cycle_ms = 100
[[property]]
name = "on within 2.1 s"
when = "I 1.0"
then = "Q 2.0 or not I 1.0"
within = "2100ms"
[[property]]
name = "on within 1.5 s"
when = "I 1.0"
then = "Q 2.0 or not I 1.0"
within = "15 cycles"
[[property]]
name = "off at once"
never = "Q 2.0 and not I 1.0"
"""
    report = prove(_files(tmp_path, ONDELAY, props), depth=25, timeout_s=300)
    assert _verdicts(report) == {"on within 2.1 s": Verdict.PROVED,
                                 "on within 1.5 s": Verdict.REFUTED,
                                 "off at once": Verdict.PROVED}
    assert any(name == "timer 2 holds at most 2000 ms" for name in report.invariants)
    _replay(report)


def test_a_reachable_counter_state_and_an_unreachable_one(tmp_path: Path):
    props = """[master]
cycle_ms = 5
[[property]]
name = "two edges counted"
reachable = "CV 1 == 2"
[[property]]
name = "three never stays"
reachable = "CV 1 >= 3"
"""
    report = prove(_files(tmp_path, COUNT3, props))
    assert _verdicts(report) == {"two edges counted": Verdict.REACHED,
                                 "three never stays": Verdict.UNREACHABLE}
    witness = report.outcomes[0]
    assert witness.trace is not None and len(witness.trace) == 3  # on, off, on
    _replay(report)


def test_an_invariant_that_needs_induction(tmp_path: Path):
    props = "[master]\ncycle_ms = 5\n[[property]]\nname = \"never one alone\"\nnever = \"Q 2.0\"\n"
    report = prove(_files(tmp_path, LOCKSTEP, props), timeout_s=300)
    assert _verdicts(report) == {"never one alone": Verdict.PROVED}


def test_the_command_line_exit_codes_and_json(tmp_path: Path, runner):
    good = _files(tmp_path, REVERSE, INTERLOCK, "good")
    bad = _files(tmp_path, RACE, INTERLOCK, "bad")
    result = runner.invoke(main, ["prove", str(good), "--timeout", "300s"])
    assert result.exit_code == 0, result.output
    assert "proved       never both directions" in result.output
    result = runner.invoke(main, ["prove", str(bad), "--format", "json", "--timeout", "300s",
                                  "--counterexamples", str(tmp_path / "cex")])
    assert result.exit_code == 1, result.output
    data = json.loads(result.output)
    results = {r["name"]: r for r in data["files"][0]["results"]}
    assert results["never both directions"]["verdict"] == "refuted"
    written = Path(results["never both directions"]["scenario"])
    assert written.parent == tmp_path / "cex" and written.is_file()


def test_a_file_in_the_way_is_not_replaced(tmp_path: Path, runner):
    bad = _files(tmp_path, RACE, INTERLOCK, "bad")
    (tmp_path / "bad.cex.never-both-directions.scenario.toml").write_text("mine\n")
    result = runner.invoke(main, ["prove", str(bad)])
    assert result.exit_code == 2
    assert "not overwritten (use --force)" in result.output
    result = runner.invoke(main, ["prove", str(bad), "--force", "--timeout", "300s"])
    assert result.exit_code == 1


@pytest.mark.parametrize(("text", "message", "column"), [
    ('never = "Q 2.0 andd Q 2.1"', "not an operand", 10),
    ('never = "Q 2.0 and (Q 2.1"', "expected and, or, xor or ')', found the end [E410]", 26),
    ('always = "FY 10"', "a condition is true or false: compare the value FY 10", 11),
    ('never = "Q 2.0 and \\u00e9"', "unexpected character '\u00e9'", 20),
    ("never = '" + "(" * 140 + "Q 2.0" + ")" * 140 + "'", "parentheses nested more than 32 deep",
     42),
    ('never = "' + " and ".join(["Q 2.0"] * 1000) + '"', "at most 4000 characters", 4010),
    ('never = "Q 2.0 < 3 < 4"', "do not chain", 20),
    ('never = "I 40.0"', "slave 0..31", 10),
])
def test_mistakes_in_expressions_point_at_their_column(tmp_path: Path, runner, text: str,
                                                       message: str, column: int):
    props = _files(tmp_path, REVERSE, f'[[property]]\nname = "x"\n{text}\n')
    result = runner.invoke(main, ["prove", str(props)])
    assert result.exit_code == 2
    assert f"p.props.toml:3:{column}: error: " in result.output
    assert message in result.output
    assert "^" in result.output


def test_a_properties_file_nested_too_deeply_is_a_source_error(tmp_path: Path, runner):
    props = _files(tmp_path, REVERSE, "a = " + "[" * 5000 + "]" * 5000 + "\n")
    result = runner.invoke(main, ["prove", str(props)])
    assert result.exit_code == 2
    assert "p.props.toml:1:37: error: not valid TOML: arrays or tables nested more than 32 deep" \
        in result.output
    assert "Traceback" not in result.output


def test_unknown_keys_and_missing_parts(tmp_path: Path):
    props = _files(tmp_path, REVERSE, '[[property]]\nname = "x"\nnevr = "Q 2.0"\n'
                   '[[property]]\nname = "y"\nwhen = "I 1.0"\n')
    with pytest.raises(Invalid) as invalid:
        prove(props)
    text = invalid.value.text
    assert "p.props.toml:3:1: error: unknown key 'nevr' in [[property]]" in text
    assert "did you mean 'never'" in text
    assert "p.props.toml:4:1: error: property 'y': when needs then and within" in text


def test_asm_is_refused_with_its_line(tmp_path: Path, runner):
    props = _files(tmp_path, SETUP + "[PROGRAM]\n    A I 1.0\n    ASM nop\n    = Q 2.0\n",
                   '[[property]]\nname = "x"\nnever = "Q 2.0"\n')
    result = runner.invoke(main, ["prove", str(props)])
    assert result.exit_code == 2
    assert "p.asi:6:" in result.output and "[E406]" in result.output
    assert "ASM line 'nop'" in result.output


def test_without_z3_the_hint_names_the_extra(tmp_path: Path, runner, monkeypatch):
    props = _files(tmp_path, REVERSE, INTERLOCK)
    monkeypatch.setitem(sys.modules, "z3", None)  # import z3 fails as if not installed
    result = runner.invoke(main, ["prove", str(props)])
    assert result.exit_code == 2
    assert "needs the 'prove' extra" in result.output
    assert "pip install 'z3-solver>=4.12'" in result.output
    old = tmp_path / "p.asi"
    result = runner.invoke(main, ["diff", str(old), str(old), "--equivalent"])
    assert result.exit_code == 2 and "needs the 'prove' extra" in result.output


LOOP = SETUP + """[PROGRAM]
        L   KB 0
        T   FY 10
loop:   L   FY 10       ; FY 10 := 16, 32, ... until it equals IB 0 (I 1 times 16)
        L   KB 16
        +   F
        T   FY 10
        L   FY 10
        L   IB 0
        ><  F
        JC  =loop
        A   F 10.5
        =   Q 2.0
***
"""


def test_a_loop_beyond_its_bound_is_reported_and_a_higher_bound_decides(tmp_path: Path):
    props = _files(tmp_path, LOOP, '[master]\ncycle_ms = 5\n[[property]]\nname = "q"\n'
                   'never = "Q 2.0 and not I 1.1"\n')
    report = prove(props)
    assert report.loops == [(10 + 4, 8)]
    outcome = report.outcomes[0]
    assert outcome.verdict is Verdict.UNKNOWN
    assert "line 14" in outcome.note and "more than 8 times" in outcome.note
    report = prove(props, unroll=16)  # I 1 = 0: 16 times round (FY 10 wraps to 0)
    assert _verdicts(report) == {"q": Verdict.PROVED}


def test_depth_as_a_time_is_cycles_of_the_program(tmp_path: Path, runner):
    props = _files(tmp_path, RACE, "[master]\ncycle_ms = 5\n" + INTERLOCK)
    result = runner.invoke(main, ["prove", str(props), "--depth", "1h"])
    assert result.exit_code == 2
    assert "--depth: 1 h 0 min is 720000 cycles of 5 ms, more than 10000" in result.stderr
    result = runner.invoke(main, ["prove", str(props), "--depth", "soon"])
    assert result.exit_code == 2 and "'soon' is not a number of cycles or a time" in result.stderr
    result = runner.invoke(main, ["prove", str(props), "--depth", "25ms", "--format", "json",
                                  "--timeout", "300s"])
    assert result.exit_code == 1, result.output
    results = {r["name"]: r for r in json.loads(result.output)["files"][0]["results"]}
    assert results["never both directions"]["verdict"] == "refuted"


def test_properties_and_assumptions_name_the_programs_symbols(tmp_path: Path):
    props = _files(tmp_path, REVERSE, """
[assume]
always = ["not (Forward and Backward)"]

[[property]]
name = "never both directions"
never = "Forward_on and Backward_on"

[[property]]
name = "forward runs"
reachable = "Forward_on xor Backward_on"
""")
    (tmp_path / "p.symbols.toml").write_text(
        'Forward = "I 1.0"\nBackward = "I 1.1"\nForward_on = "Q 2.0"\nBackward_on = "Q 2.1"\n')
    report = prove_file(props)
    assert _verdicts(report) == {"never both directions": Verdict.PROVED,
                                 "forward runs": Verdict.REACHED}
    # a name the table lacks is E410 at its place inside the string
    props.write_text('[[property]]\nname = "x"\nnever = "Forward_on and Sideways"\n')
    with pytest.raises(Invalid) as invalid:
        prove_file(props)
    assert "p.props.toml:3:25: error: 'Sideways' is not an operand" in invalid.value.text
    assert "[E410]" in invalid.value.text
