"""Every demo's properties file: each property proved or reached (the witnesses replay),
and the refuted-on-purpose example refuted with counterexamples that fail when replayed."""

from __future__ import annotations

from pathlib import Path

import pytest
from test_prove import _replay

from asictl.prove.engine import Verdict
from asictl.prove.session import prove

DEMOS = Path(__file__).resolve().parents[2] / "demos"
GOOD = sorted(p for p in DEMOS.glob("*.props.toml") if ".refuted." not in p.name)


def test_every_demo_has_a_properties_file():
    assert {p.name.split(".")[0] for p in GOOD} == {p.stem for p in DEMOS.glob("*.asi")}


@pytest.mark.parametrize("props", GOOD, ids=lambda p: p.name)
def test_the_demos_properties_hold(props: Path, tmp_path: Path):
    report = prove(props, out_dir=tmp_path, timeout_s=300)  # decided, however loaded
    assert report.passed, [(o.prop.name, o.verdict.value) for o in report.outcomes]
    _replay(report)


def test_the_refuted_example_is_refuted_and_replays(tmp_path: Path):
    report = prove(DEMOS / "timer.refuted.props.toml", out_dir=tmp_path, timeout_s=300)
    assert {o.verdict for o in report.outcomes} == {Verdict.REFUTED}
    _replay(report)
