"""A counterexample sets input bits, only those that change: a slave's other inputs hold
their value, and the scenario still fails at its last step under the simulator."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from asictl.build import build_file
from asictl.prove.engine import Verdict
from asictl.prove.session import prove as prove_file
from asictl.sim.engine import Simulation, variables_of
from asictl.sim.scenario import load_scenario

pytest.importorskip("z3")

#: Q 3.1 latches on I 1.0 and I 1.1 together and I 1.2 resets it: never with I 1.3.
PROGRAM = """[SETUP]
1: iiii, 0
3: oooo, 0

[PROGRAM]
        A   I 1.0
        A   I 1.1
        S   Q 3.1
***
        A   I 1.2
        R   Q 3.1
***
"""


def test_a_counterexample_sets_single_bits_and_replays(tmp_path: Path):
    (tmp_path / "p.asi").write_text(PROGRAM)
    props = tmp_path / "p.props.toml"
    props.write_text('[master]\ncycle_ms = 10\n[[property]]\nname = "x"\n'
                     'never = "Q 3.1 and I 1.3"\n')
    report = prove_file(props, timeout_s=300.0)
    [outcome] = report.outcomes
    assert outcome.verdict is Verdict.REFUTED
    text = report.written["x"].read_text()
    keys = re.findall(r'"([^"]+)" = ', text.split("expect")[0])
    assert keys and all(re.fullmatch(r"I 1\.[0-3]", key) for key in keys), text
    built = build_file(tmp_path / "p.asi")
    assert built.image is not None
    scenario = load_scenario(report.written["x"], variables_of(built.image.pmap))
    result = Simulation(built, scenario).run()
    last = max(step.at_ms for step in scenario.steps)
    assert result.failures and {f.at_ms for f in result.failures} == {last}


def test_the_counterexample_names_its_operands_by_the_symbol_table(tmp_path: Path):
    (tmp_path / "p.asi").write_text(PROGRAM)
    (tmp_path / "p.symbols.toml").write_text('Start = "I 1.0"\nPumpB = "Q 3.1"\n')
    props = tmp_path / "p.props.toml"
    props.write_text('[master]\ncycle_ms = 10\n[[property]]\nname = "x"\n'
                     'never = "Q 3.1 and I 1.3"\n')
    report = prove_file(props, timeout_s=300.0)
    text = report.written["x"].read_text()
    [names] = [line for line in text.splitlines() if line.startswith("# names: ")]
    assert "I 1.0 (Start)" in names and "Q 3.1 (PumpB)" in names
    assert "I 1.1" not in names  # no name: nothing to say
