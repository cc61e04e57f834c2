"""asictl test -j: a scenario whose worker process dies (as the OOM killer or a signal
would end it) is an ERROR row with a JUnit <error>; the other scenarios keep their
results and their coverage, and the run exits 1, never with BrokenProcessPool."""

from __future__ import annotations

import json
import os
import shutil
import signal
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import pytest
from click.testing import CliRunner

import asictl.sim.session as session
from asictl.cli import main

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def project(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Six scenarios of blink; the one named dies.scenario.toml kills its own process."""
    monkeypatch.chdir(tmp_path)
    shutil.copy(ROOT / "demos" / "blink.asi", tmp_path / "blink.asi")
    text = (ROOT / "demos" / "blink.scenario.toml").read_text()
    text = text if "program" in text else 'program = "blink.asi"\n' + text
    for name in ("a", "b", "dies", "c", "d", "e"):
        (tmp_path / f"{name}.scenario.toml").write_text(text)
    real = session.simulate

    def simulate(prepared: Any, *args: Any, **kwargs: Any) -> Any:
        if Path(prepared.scenario.file).name == "dies.scenario.toml":
            os.kill(os.getpid(), signal.SIGKILL)
        return real(prepared, *args, **kwargs)

    monkeypatch.setattr(session, "simulate", simulate)  # the forked workers inherit it
    return tmp_path


@pytest.mark.parametrize("jobs", ["2", "3"])
def test_a_dead_worker_is_an_error_row_and_the_rest_keep_their_results(
    project: Path, jobs: str
):
    result = CliRunner().invoke(main, ["test", "-j", jobs, ".", "--junit", "out.xml",
                                       "--coverage", "cov.json"])
    assert result.exit_code == 1, result.output
    assert "BrokenProcessPool" not in result.output
    rows = [line for line in result.output.splitlines() if line.split(" ")[0] in
            ("PASS", "FAIL", "ERROR")]
    assert [row.split(" ")[1].rstrip(":") for row in rows] == [
        f"{name}.scenario.toml" for name in ("a", "b", "c", "d", "dies", "e")]
    assert [row.split(" ")[0] for row in rows] == ["PASS"] * 4 + ["ERROR", "PASS"]
    assert rows[4] == f"ERROR dies.scenario.toml: {session.WORKER_DIED}"
    assert "5 passed, 1 failed" in result.output
    suite = ElementTree.parse(project / "out.xml").getroot()
    assert suite.get("errors") == "1" and suite.get("tests") == "6"
    errors = [case.get("name") for case in suite.iter("testcase")
              if case.find("error") is not None]
    assert errors == ["dies.scenario.toml"]
    coverage = json.loads((project / "cov.json").read_text())
    assert coverage  # the other five scenarios' coverage is written
    assert "coverage: lines 100%" in result.output


def test_without_a_death_the_run_is_as_before(project: Path):
    (project / "dies.scenario.toml").unlink()
    result = CliRunner().invoke(main, ["test", "-j", "2", "."])
    assert result.exit_code == 0, result.output
    assert "5 passed, 0 failed" in result.output
