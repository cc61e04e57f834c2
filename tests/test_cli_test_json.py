"""``asictl test --format json``: one JSON document, an entry per scenario in the stable
order whatever -j is, a summary; each entry written as soon as it and the ones before it
are done."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

from click.testing import CliRunner

from asictl.cli import main

ROOT = Path(__file__).resolve().parent.parent


def _scenarios(tmp_path: Path) -> list[Path]:
    """blink (passes), a blink that fails one expectation, and an invalid scenario."""
    shutil.copy(ROOT / "demos" / "blink.asi", tmp_path / "blink.asi")
    shutil.copy(ROOT / "demos" / "blink.asi", tmp_path / "wrong.asi")
    scenario = (ROOT / "demos" / "blink.scenario.toml").read_text()
    (tmp_path / "blink.scenario.toml").write_text(scenario)
    wrong = scenario.replace('at_ms = 750\nexpect = { "Q 31.0" = 0 }',
                             'at_ms = 750\nexpect = { "Q 31.0" = 1 }')
    assert wrong != scenario
    (tmp_path / "wrong.scenario.toml").write_text(wrong)
    (tmp_path / "x.scenario.toml").write_text('program = "missing.asi"\n')
    return sorted(tmp_path.glob("*.scenario.toml"))


def test_json_has_an_entry_per_scenario_and_a_summary(tmp_path: Path):
    paths = _scenarios(tmp_path)
    for jobs in ("1", "2"):
        result = CliRunner().invoke(main, ["test", str(tmp_path), "--format", "json",
                                           "-j", jobs])
        assert result.exit_code == 2, result.output  # an invalid scenario among them
        document = json.loads(result.stdout)
        entries = document["scenarios"]
        assert [e["path"] for e in entries] == [str(p) for p in paths]
        assert [e["status"] for e in entries] == ["PASS", "FAIL", "ERROR"]
        assert entries[1]["failures"][0]["text"] == "at 750 ms: Q 31.0 expected 1, got 0"
        assert entries[1]["program"] == str(tmp_path / "wrong.asi")
        assert entries[2]["program"] is None and "missing.asi" in entries[2]["message"]
        assert document["summary"] == {"total": 3, "passed": 1, "failed": 1, "errors": 1}


def test_each_entry_is_a_line_of_its_own_as_it_is_written(tmp_path: Path):
    """Read as a stream, line by line: the opening, one entry a line (each JSON by
    itself), then the summary; together one JSON document."""
    _scenarios(tmp_path)
    (tmp_path / "x.scenario.toml").unlink()
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", "test", str(tmp_path), "--format", "json", "-j", "1"],
        stdout=subprocess.PIPE, text=True, env={"PYTHONPATH": str(ROOT / "src"),
                                                "PATH": "/usr/bin:/bin"},
    )
    assert process.stdout is not None
    lines = process.stdout.readlines()
    assert process.wait(timeout=120) == 1
    assert lines[0] == '{"scenarios": [\n' and lines[-1].startswith('], "summary": ')
    entries = [json.loads(line.removeprefix(", ")) for line in lines[1:-1]]
    assert [e["status"] for e in entries] == ["PASS", "FAIL"]
    assert json.loads("".join(lines))["scenarios"] == entries
