"""The demo programs: one per line of the manual's demo list, each proven by its scenario."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.cli import main

ROOT = Path(__file__).resolve().parent.parent
DEMOS = ROOT / "demos"
MANUAL_LIST = ["counter", "edge", "fb", "first", "flipflop", "gating", "jump", "logic",
               "offdelay", "ondelay", "oscil", "param", "pulse", "timer", "1h_timer"]


def test_every_demo_of_the_manual_is_there_with_a_scenario():
    manual = (ROOT.parent / "shared" / "seeds" / "000_5be761f10bdfdbd0.txt")
    if manual.exists():  # the list as the manual prints it
        assert re.findall(r"^\| ([\w]+)\.asi", manual.read_text(), re.M) == MANUAL_LIST
    for name in MANUAL_LIST:
        assert (DEMOS / f"{name}.asi").is_file()
        assert (DEMOS / f"{name}.scenario.toml").is_file()


def test_asictl_test_demos_passes():
    """The bar as CI runs it: every demo's scenario, through ``asictl test demos/``."""
    scenarios = sorted(DEMOS.glob("*.scenario.toml"))
    result = CliRunner().invoke(main, ["test", str(DEMOS)])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[-1] == f"{len(scenarios)} passed, 0 failed"
    assert all(re.search(r"PASS .*: [1-9]\d* expectations, 0 failed", line)
               for line in result.output.splitlines() if line.startswith("PASS"))


def test_demos_check_clean_without_warnings():
    result = CliRunner().invoke(main, ["check", "--werror", str(DEMOS)])
    assert result.exit_code == 0, result.stderr


def test_demo_docs_show_every_demo_and_its_diagram():
    text = (ROOT / "docs" / "demos.md").read_text()
    for name in MANUAL_LIST:
        assert f"## {name}" in text
        assert (ROOT / "docs" / "demos" / f"{name}.png").is_file()
        assert (DEMOS / f"{name}.asi").read_text().rstrip() in text


def test_pytest_demos_runs_the_python_demo_test(pytester: pytest.Pytester):
    """``pytest demos/`` (README): the Python test there passes, the fixture found."""
    result = pytester.runpytest_inprocess(str(DEMOS / "test_sequence.py"), "-p",
                                          "no:cacheprovider")
    result.assert_outcomes(passed=2)
