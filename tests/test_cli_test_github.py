"""``asictl test --format github``: a failed expectation is an annotation at its line."""

from __future__ import annotations

import shutil
from pathlib import Path

from click.testing import CliRunner

from asictl.cli import main

ROOT = Path(__file__).resolve().parent.parent


def test_failed_expectations_are_annotated_at_their_scenario_line(tmp_path: Path):
    shutil.copy(ROOT / "demos" / "blink.asi", tmp_path / "blink.asi")
    scenario = (ROOT / "demos" / "blink.scenario.toml").read_text()
    wrong = scenario.replace('at_ms = 750\nexpect = { "Q 31.0" = 0 }',
                             'at_ms = 750\nexpect = { "Q 31.0" = 1 }')
    assert wrong != scenario
    path = tmp_path / "blink.scenario.toml"
    path.write_text(wrong)
    line = wrong.splitlines().index('expect = { "Q 31.0" = 1 }', 7) + 1
    result = CliRunner().invoke(main, ["test", str(tmp_path), "--format", "github"])
    assert result.exit_code == 1
    annotations = [x for x in result.stdout.splitlines() if x.startswith("::")]
    assert annotations == [
        f"::error file={path},line={line},title=expectation failed::"
        "at 750 ms: Q 31.0 expected 1, got 0"
    ]
    assert "FAIL" in result.stdout and "0 passed, 1 failed" in result.stdout


def test_text_format_has_no_annotations_and_passing_runs_none():
    text = CliRunner().invoke(main, ["test", "demos/blink.scenario.toml"])
    github = CliRunner().invoke(main, ["test", "demos/blink.scenario.toml", "--format", "github"])
    assert text.exit_code == github.exit_code == 0
    assert "::" not in text.stdout and "::" not in github.stdout


def test_an_invalid_scenario_is_annotated_at_its_file(tmp_path: Path):
    path = tmp_path / "x.scenario.toml"
    path.write_text('program = "missing.asi"\n')
    result = CliRunner().invoke(main, ["test", str(path), "--format", "github"])
    assert result.exit_code == 2
    assert f"::error file={path},title=asictl test::" in result.stdout
