"""With map_counters the master keeps bits 4-7 of a counter's high flag byte at 0, after
every cycle and whatever the host writes there; the prover must too, or it refutes what
the simulator shows true (a counterexample that passes under ``asictl sim``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from asictl.build import build_file
from asictl.prove.engine import Verdict
from asictl.prove.session import prove as prove_file
from asictl.sim.engine import Simulation, variables_of
from asictl.sim.scenario import load_scenario

pytest.importorskip("z3")

#: FY 97 is counter 0's high byte: the program writes 255 there, the master keeps 15.
PROGRAM = """[OPTIONS]
map_counters: yes

[SETUP]
1: iiii, 0
3: oooo, 0

[PROGRAM]
        ; asictl: host FY 99
        AN  I 1.0
        JC  skip
        L   KB 255
        T   FY 97
skip:
        L   FY 99
        T   FY 20
        A   C 0
        =   Q 3.1
***
"""

PROPERTIES = """[master]
cycle_ms = 10
[[property]]
name = "the program's write is kept within 0..15"
never = "FY 97 > 15"
[[property]]
name = "the host's write too"
never = "FY 20 > 15"
[[property]]
name = "15 is reached"
reachable = "FY 97 == 15 and FY 20 == 15"
"""


def test_the_high_byte_of_a_mapped_counter_stays_within_0_to_15(tmp_path: Path):
    (tmp_path / "p.asi").write_text(PROGRAM)
    props = tmp_path / "p.props.toml"
    props.write_text(PROPERTIES)
    report = prove_file(props, timeout_s=300.0)
    verdicts = {o.prop.name: (o.verdict, o.trivially) for o in report.outcomes}
    assert verdicts == {
        "the program's write is kept within 0..15": (Verdict.PROVED, ""),
        "the host's write too": (Verdict.PROVED, ""),
        "15 is reached": (Verdict.REACHED, ""),
    }
    # the witness replays: the simulator shows the same 15
    built = build_file(tmp_path / "p.asi")
    assert built.image is not None
    witness = load_scenario(report.written["15 is reached"], variables_of(built.image.pmap))
    assert Simulation(built, witness).run().passed


#: The program writes 255 to counter 0's high byte and reads it back in the same cycle.
READ_BACK = """[OPTIONS]
map_counters: yes

[SETUP]
1: iiii, 0

[PROGRAM]
        L   KB 255
        T   FY 97
        L   FY 97
        T   FY 20
        ON  F 0.0
        S   F 99.7
        A   F 99.7
        =   F 21.0
***
"""

READ_BACK_PROPERTIES = """[master]
cycle_ms = 10
[[property]]
name = "the byte read back holds the count's four bits"
always = "FY 20 == 15"
[[property]]
name = "a bit above them stays 0"
never = "F 21.0"
"""


def test_a_mapped_high_byte_read_back_in_the_same_cycle_is_masked(tmp_path: Path):
    (tmp_path / "p.asi").write_text(READ_BACK)
    props = tmp_path / "p.props.toml"
    props.write_text(READ_BACK_PROPERTIES)
    report = prove_file(props, timeout_s=300.0)
    verdicts = {o.prop.name: o.verdict for o in report.outcomes}
    assert verdicts == {
        "the byte read back holds the count's four bits": Verdict.PROVED,
        "a bit above them stays 0": Verdict.PROVED,
    }
