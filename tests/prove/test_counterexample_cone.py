"""A counterexample sets only inputs in the property's cone of influence, and of those
only the changes the failure needs: everything else holds its value. It is the
shortest there is, and it still fails at its last step under ``asictl sim``."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from replay import assert_replays
from test_counterexample_bits import PROGRAM as LATCH

from asictl.prove.engine import Verdict
from asictl.prove.session import Report
from asictl.prove.session import prove as prove_file

pytest.importorskip("z3")

#: Q 3.1 is latched by I 1.0 and I 1.1, reset by I 1.2; F 0.0 remembers I 2.2 from an
#: earlier cycle and with I 2.3 sets Q 3.0. I 1.3, I 2.0 and I 2.1 drive Q 3.2 and Q 3.3,
#: which no property reads: outside every cone.
PROGRAM = LATCH.replace("3: oooo, 0", "2: iiii, 0\n3: oooo, 0") + """        A   F 0.0
        A   I 2.3
        =   Q 3.0
***
        A   I 2.2
        =   F 0.0
***
        A   I 2.0
        O   I 1.3
        =   Q 3.2
***
        A   I 2.1
        AN  I 1.3
        =   Q 3.3
***
"""


def _prove(tmp_path: Path, properties: str) -> Report:
    (tmp_path / "p.asi").write_text(PROGRAM)
    props = tmp_path / "p.props.toml"
    props.write_text("[master]\ncycle_ms = 10\n" + properties)
    return prove_file(props, timeout_s=300.0)


def _sets(path: Path) -> list[tuple[float, dict[str, str]]]:
    """Each step's time and what it sets."""
    found = []
    for block in path.read_text().split("[[step]]")[1:]:
        at = float(re.search(r"at_ms = ([0-9.]+)", block)[1])  # type: ignore[index]
        sets = re.search(r"set = \{(.*)\}", block)
        pairs = re.findall(r'"([^"]+)" = (\w+)', sets[1]) if sets else []
        found.append((at, dict(pairs)))
    return found


def _replays_to_its_last_step(report: Report, name: str) -> None:
    assert_replays(report.program, report.written[name], Verdict.REFUTED)


def test_only_the_inputs_the_failure_needs_are_set(tmp_path: Path):
    report = _prove(tmp_path, '[[property]]\nname = "latch"\nnever = "Q 3.1"\n')
    [outcome] = report.outcomes
    assert outcome.verdict is Verdict.REFUTED and outcome.depth == 0  # the shortest
    steps = _sets(report.written["latch"])
    setting = [s for s in steps if s[1]]
    assert setting == [(0.0, {"I 1.0": "1", "I 1.1": "1"})]
    _replays_to_its_last_step(report, "latch")


def test_an_input_in_the_cone_through_a_flag_of_an_earlier_cycle(tmp_path: Path):
    """Q 3.0 needs F 0.0 from the cycle before: I 2.2 is set in the first cycle and I 2.3
    (in the first or the second), nothing else, and nothing is set twice."""
    report = _prove(tmp_path, '[[property]]\nname = "flag"\nnever = "Q 3.0"\n')
    [outcome] = report.outcomes
    assert outcome.verdict is Verdict.REFUTED and outcome.depth == 1
    steps = _sets(report.written["flag"])
    keys = [key for _, sets in steps for key in sets]
    assert sorted(keys) == ["I 2.2", "I 2.3"], steps
    _replays_to_its_last_step(report, "flag")


def test_unrelated_inputs_are_never_set_in_a_longer_counterexample(tmp_path: Path):
    """Set, reset and set again: the latch's inputs change as the failure needs them,
    the unrelated ones (I 1.3, I 2.0, I 2.1) never."""
    report = _prove(tmp_path, """[[property]]
name = "never set after a reset"
never = "Q 3.1 and I2 1.2 and not I 1.2 and I 2.3"
""")
    [outcome] = report.outcomes
    assert outcome.verdict is Verdict.REFUTED
    keys = {key for _, sets in _sets(report.written["never set after a reset"])
            for key in sets}
    assert keys <= {"I 1.0", "I 1.1", "I 1.2", "I 2.3"}, keys
    assert not keys & {"I 1.3", "I 2.0", "I 2.1", "I 2.2"}
    _replays_to_its_last_step(report, "never set after a reset")
