"""No vacuous verdicts: a property over an operand the program and its bus do not have is
bad input at its place inside the string, and a property that holds whatever the program
does says so (``proved (trivially: ...)``) rather than a bare ``proved``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from asictl.cli import main
from asictl.prove.engine import Verdict
from asictl.prove.session import Invalid
from asictl.prove.session import prove as prove_file

pytest.importorskip("z3")

PROGRAM = """[SETUP]
1: iiii, 0
3: oooo, 0

[PROGRAM]
        L   KT 500
        A   I 1.0
        AN  I 1.2
        S   T 1
        A   I 1.0
        AN  T 1
        =   Q 3.1
        A   I 1.1
        =   F 4.0
***
"""


def _files(tmp_path: Path, properties: str) -> Path:
    (tmp_path / "p.asi").write_text(PROGRAM)
    props = tmp_path / "p.props.toml"
    props.write_text("[master]\ncycle_ms = 10\n" + properties)
    return props


@pytest.mark.parametrize(("text", "message", "column"), [
    # no slave 9 on the bus: a typo of Q 3.0 that used to come out "proved"
    ('never = "I 1.0 and Q 9.0"', "'Q 9.0': slave 9 is not on the bus (slaves 1 3", 20),
    ('never = "Q 9.0"', "; did you mean 'Q 3.0'? [E430]", 10),
    # not a timer the program has: it used to come out "proved"
    ('never = "T 99"', "'T 99': the program does not use timer 99; did you mean 'T 1'?", 10),
    ('always = "TV 2 <= 5s"', "the program does not use timer 2", 11),
    ('reachable = "CV 0 == 2"', "'CV 0': the program uses no counter [E430]", 14),
    ('never = "QB 8 != 0"', "'QB 8': slave 8 or 9 is not on the bus", 10),
])
def test_an_operand_the_program_lacks_is_an_error_at_its_place(
        tmp_path: Path, runner, text: str, message: str, column: int):
    props = _files(tmp_path, f'[[property]]\nname = "x"\n{text}\n')
    result = runner.invoke(main, ["prove", str(props)])
    assert result.exit_code == 2, result.output
    assert f"p.props.toml:5:{column}: error: " in result.output
    assert message in result.output
    assert "proved" not in result.output


def test_an_assumption_over_a_slave_not_there_is_an_error(tmp_path: Path):
    props = _files(tmp_path, '[assume]\nalways = ["not I 7.2"]\n'
                   '[[property]]\nname = "x"\nnever = "Q 3.1 and not I 1.0"\n')
    with pytest.raises(Invalid) as invalid:
        prove_file(props)
    assert "p.props.toml:4:16: error: 'I 7.2': slave 7 is not on the bus" in invalid.value.text
    assert "  always = [\"not I 7.2\"]\n                 ^~~~~" in invalid.value.text


def test_the_slaves_of_master_make_the_bus(tmp_path: Path):
    """[master] slaves replace [SETUP]: slave 9 is there, slave 3 is not."""
    props = _files(tmp_path, '[[property]]\nname = "x"\nnever = "Q 9.0"\n')
    props.write_text('[master]\ncycle_ms = 10\nslaves = { 1 = "iiii,0", 9 = "oooo,0" }\n'
                     '[[property]]\nname = "x"\nnever = "Q 9.0 or Q 3.1"\n')
    with pytest.raises(Invalid) as invalid:
        prove_file(props, timeout_s=300.0)
    assert "'Q 3.1': slave 3 is not on the bus (slaves 1 9" in invalid.value.text
    assert "'Q 9.0'" not in invalid.value.text


def test_an_unknown_symbol_suggests_the_nearest_name(tmp_path: Path):
    props = _files(tmp_path, '[[property]]\nname = "x"\nnever = "PumpB and not Strat"\n')
    (tmp_path / "p.symbols.toml").write_text('Start = "I 1.0"\nPumpB = "Q 3.1"\n')
    with pytest.raises(Invalid) as invalid:
        prove_file(props)
    assert "p.props.toml:5:24: error: 'Strat' is not an operand" in invalid.value.text
    assert "did you mean 'Start'?" in invalid.value.text


def test_a_property_true_whatever_the_program_does_is_proved_trivially(tmp_path: Path,
                                                                      runner):
    props = _files(tmp_path, """
[assume]
always = ["not (I 1.0 and I 1.2)"]
[[property]]
name = "tautology"
always = "Q 3.1 or not Q 3.1"
[[property]]
name = "contradiction"
never = "F 4.0 and not F 4.0"
[[property]]
name = "assumed"
never = "I 1.0 and I 1.2"
[[property]]
name = "a flag the program never writes"
never = "F 9.3"
[[property]]
name = "the real interlock"
never = "Q 3.1 and not I 1.0"
[[property]]
name = "a state never reached"
reachable = "FY 9 == 1"
""")
    report = prove_file(props, timeout_s=300.0)
    trivial = {o.prop.name: (o.verdict, o.trivially) for o in report.outcomes}
    assert trivial["tautology"] == (Verdict.PROVED, "'Q 3.1 or not Q 3.1' holds in every state")
    assert trivial["contradiction"] == (Verdict.PROVED,
                                        "'F 4.0 and not F 4.0' holds in no state")
    assert trivial["assumed"] == (Verdict.PROVED,
                                  "'I 1.0 and I 1.2' holds in no state [assume] allows")
    assert trivial["a flag the program never writes"][0] is Verdict.PROVED
    assert "no cycle of the program changes 'F 9.3'" in trivial[
        "a flag the program never writes"][1]
    assert trivial["the real interlock"] == (Verdict.PROVED, "")
    assert trivial["a state never reached"][0] is Verdict.UNREACHABLE
    assert trivial["a state never reached"][1]

    result = runner.invoke(main, ["prove", str(props)])
    assert result.exit_code == 1, result.output  # unreachable is not reached
    lines = {line.split()[1]: line for line in result.stdout.splitlines()
             if line.startswith("  proved")}
    assert "(trivially: 'Q 3.1 or not Q 3.1' holds in every state)" in lines["tautology"]
    assert "trivially" not in lines["the"]
    assert "(k-induction" in lines["the"] or "(invariant" in lines["the"]
    result = runner.invoke(main, ["prove", str(props), "--format", "json"])
    results = {r["name"]: r for r in json.loads(result.stdout)["files"][0]["results"]}
    assert results["the real interlock"]["trivially"] is None
    assert results["tautology"]["says"].startswith("proved (trivially: ")


def test_the_reason_names_operands_as_the_verdicts_do(tmp_path: Path, runner):
    """A property written with a symbol or with the operand reads alike in the reason:
    ``Q 3.1 (PumpB)``, as in every other verdict line and note."""
    props = _files(tmp_path, """
[[property]]
name = "tautology"
always = "PumpB or not Q 3.1"
[[property]]
name = "a flag the program never writes"
never = "Spare and F 9.4"
""")
    (tmp_path / "p.symbols.toml").write_text('PumpB = "Q 3.1"\nSpare = "F 9.3"\n')
    report = prove_file(props, timeout_s=300.0)
    reasons = {o.prop.name: o.trivially for o in report.outcomes}
    assert reasons["tautology"] == \
        "'Q 3.1 (PumpB) or not Q 3.1 (PumpB)' holds in every state"
    assert reasons["a flag the program never writes"].startswith(
        "no cycle of the program changes 'F 9.3 (Spare) and F 9.4'")
    result = runner.invoke(main, ["prove", str(props)])
    assert "(trivially: 'Q 3.1 (PumpB) or not Q 3.1 (PumpB)' holds in every state)" in \
        result.stdout


def test_a_property_over_inputs_alone_is_warned_of(tmp_path: Path, runner):
    props = _files(tmp_path, '[[property]]\nname = "inputs"\nnever = "I 1.0 and I 1.1"\n'
                   '[[property]]\nname = "outputs"\nnever = "Q 3.1 and I 1.1"\n')
    result = runner.invoke(main, ["prove", str(props)])
    assert result.exit_code == 1  # the inputs are free: refuted
    assert ("p.props.toml:5:10: warning: property 'inputs' is decided by the environment "
            "alone: the program writes none of I 1.0, I 1.1 [W431]") in result.stderr
    assert "'outputs'" not in result.stderr
