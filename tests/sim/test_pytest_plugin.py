"""The pytest plugin: scenario files as pytest items, with -k, markers and pytest-xdist."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "tests" / "scenarios" / "blink.asi"
PLUGIN = ("-p", "asictl.pytest_plugin")


@pytest.fixture
def folder(pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch) -> pytest.Pytester:
    """Scenarios that pass, fail, are broken or marked slow; only the plugins named on
    the command line are loaded, whether or not asictl's entry point is installed."""
    monkeypatch.setenv("PYTEST_DISABLE_PLUGIN_AUTOLOAD", "1")
    pytester.path.joinpath("blink.asi").write_text(BLINK.read_text())
    good = '[master]\ncycle_ms = 5\n[[step]]\nat_ms = 250\nexpect = { "Q 31.0" = 1 }\n'
    pytester.path.joinpath("blink.scenario.toml").write_text(good)
    pytester.path.joinpath("late.scenario.toml").write_text(
        'program = "blink.asi"\nmarkers = ["slow"]\n' + good.replace("250", "2250"))
    pytester.path.joinpath("wrong.scenario.toml").write_text(
        'program = "blink.asi"\n' + good.replace('"Q 31.0" = 1', '"Q 31.0" = 0'))
    pytester.path.joinpath("broken.scenario.toml").write_text(
        'program = "blink.asi"\n[[step]]\nat_ms = nan\n')
    return pytester


def test_scenarios_are_items_with_their_failures_as_scenario_lines(folder: pytest.Pytester):
    result = folder.runpytest(*PLUGIN, "-v")
    result.assert_outcomes(passed=2, failed=2)
    result.stdout.fnmatch_lines([
        "*blink.scenario.toml::blink PASSED*",
        "*wrong.scenario.toml::wrong FAILED*",
    ])
    result.stdout.fnmatch_lines(["*wrong.scenario.toml:6: at 250 ms: Q 31.0 expected 0, got 1"])
    result.stdout.fnmatch_lines(["*broken.scenario.toml:3:9: error: at_ms is a time*"])


def test_selection_by_keyword_and_marker(folder: pytest.Pytester):
    folder.runpytest(*PLUGIN, "-k", "blink or late").assert_outcomes(passed=2)
    folder.runpytest(*PLUGIN, "-m", "slow").assert_outcomes(passed=1)
    folder.runpytest(*PLUGIN, "-m", "not slow", "-k", "not broken").assert_outcomes(
        passed=1, failed=1)


def test_the_plugin_can_be_turned_off(folder: pytest.Pytester):
    folder.makeini("[pytest]\nasictl_scenarios = false\n")
    assert folder.runpytest(*PLUGIN).ret == pytest.ExitCode.NO_TESTS_COLLECTED


def test_with_xdist_workers(folder: pytest.Pytester):
    """A folder of 30 scenario files over two workers: 30 passed."""
    for name in ("wrong", "broken"):
        folder.path.joinpath(f"{name}.scenario.toml").unlink()
    for i in range(28):
        folder.path.joinpath(f"copy{i}.scenario.toml").write_text(
            folder.path.joinpath("blink.scenario.toml").read_text()
            .replace("[master]", 'program = "blink.asi"\n[master]'))
    result = folder.runpytest_subprocess(*PLUGIN, "-p", "xdist.plugin", "-n", "2")
    result.assert_outcomes(passed=30)


def test_the_entry_point_is_declared():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert project["project"]["entry-points"]["pytest11"] == {"asictl": "asictl.pytest_plugin"}
    assert any(r.startswith("pytest-xdist") for r in project["project"]["optional-dependencies"]
               ["test"])


def test_the_projects_own_run_does_not_collect_its_scenario_files():
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "--collect-only", "-q", *PLUGIN, "tests/scenarios"],
        cwd=ROOT, capture_output=True, text=True,
        env={"PYTEST_DISABLE_PLUGIN_AUTOLOAD": "1", "PYTHONPATH": str(ROOT / "src"),
             "PATH": "/usr/bin:/bin"},
    )
    assert result.returncode == pytest.ExitCode.NO_TESTS_COLLECTED, result.stdout
