"""A counterexample or witness that depends on a firmware block's answer (which the
prover leaves free) says so, in its verdict's note and in the scenario it writes."""

from __future__ import annotations

from pathlib import Path

import pytest

from asictl.prove.engine import Verdict
from asictl.prove.session import prove as prove_file

pytest.importorskip("z3")

#: Q 3.1 shows what GetLAS answers about slave 1; Q 5.0 follows I 1.0.
PROGRAM = """[SETUP]
1: iiii, 0
3: oooo, 0
5: oooo, 0

[PROGRAM]
        JU  FB GetLAS
        L   PSeg 4
        T   FY 30
***
        A   F 30.1
        =   Q 3.1
***
        A   I 1.0
        =   Q 5.0
***
"""

PROPERTIES = """[master]
cycle_ms = 10
[[property]]
name = "slave 1 shows"
reachable = "Q 3.1"
[[property]]
name = "the input shows"
reachable = "Q 5.0"
"""


def test_a_witness_resting_on_a_firmware_answer_says_so(tmp_path: Path):
    (tmp_path / "p.asi").write_text(PROGRAM)
    props = tmp_path / "p.props.toml"
    props.write_text(PROPERTIES)
    report = prove_file(props, timeout_s=300.0)
    by_name = {o.prop.name: o for o in report.outcomes}
    assert {o.verdict for o in report.outcomes} == {Verdict.REACHED}
    assert "firmware block's answer" in by_name["slave 1 shows"].note
    assert "firmware" not in by_name["the input shows"].note
    scenario = report.written["slave 1 shows"].read_text()
    assert "# note: it may rest on a firmware block's answer" in scenario
    assert "firmware" not in report.written["the input shows"].read_text()
