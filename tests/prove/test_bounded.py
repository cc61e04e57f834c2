"""A bounded verdict says what lies beyond its bound: each timer of the property's cone
that runs longer than the cycles searched, and a depth that would cover it."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from asictl.cli import main
from asictl.prove.engine import Verdict
from asictl.prove.session import prove as prove_file

pytest.importorskip("z3")

#: Q 3.1 comes on 20 s after I 1.0 did (an on-delay), Q 3.2 follows I 1.1 at once; FW 20
#: shows the time left (a timer's word read, so every cycle is searched one by one).
LONG = """[SETUP]
1: iiii, 0
3: oooo, 0

[PROGRAM]
        L   KT 20000
        A   I 1.0
        AN  I2 1.0
        S   T 1
***
        AN  I 1.0
        R   T 1
***
        A   I 1.0
        AN  T 1
        =   Q 3.1
***
        A   I 1.1
        =   Q 3.2
***
        L   T 1
        T   FW 20
***
"""


def _files(tmp_path: Path, properties: str) -> Path:
    (tmp_path / "p.asi").write_text(LONG)
    props = tmp_path / "p.props.toml"
    props.write_text("[master]\ncycle_ms = 10\n" + properties)
    return props


def test_a_timer_past_the_bound_is_named_with_the_depth_it_needs(tmp_path: Path, runner):
    props = _files(tmp_path, '[[property]]\nname = "the delayed output"\nnever = "Q 3.1"\n')
    report = prove_file(props, depth=5, timeout_s=2.0)
    [outcome] = report.outcomes
    assert outcome.verdict is Verdict.BOUNDED, outcome.note  # (the rest of the time: PDR)
    assert outcome.note == ("T 1 is loaded with 20000 ms = 2000 cycles of 10 ms: not "
                            "covered by depth 6; try --depth 2100 or --depth 21s")
    (tmp_path / "p.symbols.toml").write_text('Delay = "T 1"\n')
    result = runner.invoke(main, ["prove", str(props), "--depth", "5", "--timeout", "2s"])
    assert "    note: T 1 (Delay) is loaded with 20000 ms = 2000 cycles" in result.stdout


def test_a_timer_outside_the_cone_is_not_named(tmp_path: Path):
    props = _files(tmp_path, '[[property]]\nname = "follows"\nalways = "Q 3.2 == I 1.1"\n'
                   '[[property]]\nname = "x"\nreachable = "Q 3.2 and not I 1.1"\n')
    report = prove_file(props, depth=3, timeout_s=300.0)
    assert all("T 1" not in o.note for o in report.outcomes)


def test_a_time_limit_reads_as_a_duration(tmp_path: Path):
    """``time limit (24.8161 s)`` once, or ``(2.48161e-05 s)``: the limit and the time
    spent as durations people read."""
    props = _files(tmp_path, '[[property]]\nname = "x"\nnever = "Q 3.1"\n')
    [outcome] = prove_file(props, depth=5, timeout_s=24.8161e-6).outcomes
    assert outcome.verdict is Verdict.UNKNOWN
    assert re.fullmatch(r"time limit \(24\.8 µs\) (while building the model|after \d+ "
                        r"cycles), [\d.]+ (µs|ms|s) since (the start|it started)",
                        outcome.note), outcome.note


def test_the_timeout_says_what_time_it_counts(runner):
    result = runner.invoke(main, ["prove", "--help"])
    assert "Wall-clock time for each property" in result.output
