"""docs/debugging.md shows real output: every command of its worked example runs here and
prints what the page says (wall-clock times aside)."""

from __future__ import annotations

import re
import shlex
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.cli import main

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "debugging.md"


def _blocks(kind: str) -> list[str]:
    return re.findall(rf"```{kind}\n(.*?)```", DOC.read_text(), re.S)


def _sessions() -> list[tuple[str, list[str]]]:
    found = []
    for block in _blocks("console"):
        lines = block.splitlines()
        assert lines[0].startswith("$ asictl "), lines[0]
        found.append((lines[0][2:], lines[1:]))
    return found


def _normal(lines: list[str]) -> list[str]:
    return [re.sub(r"in [\d.]+ (µs|ms|s)$", "in T", line) for line in lines]


@pytest.mark.parametrize(("command", "shown"), _sessions(), ids=lambda x: str(x)[:40])
def test_each_command_prints_what_the_page_shows(command, shown, tmp_path, monkeypatch):
    for path in (ROOT / "docs" / "debugging").iterdir():
        shutil.copy(path, tmp_path / path.name)
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, shlex.split(command)[1:])
    assert result.exit_code in (0, 1), result.output
    assert _normal(result.stdout.splitlines()) == _normal(shown)
    if "--trace-il trace.csv" in command:
        [csv] = _blocks("csv")
        assert (tmp_path / "trace.csv").read_text() == csv


def test_the_page_has_the_example_and_its_diagram():
    assert len(_sessions()) >= 5
    assert (ROOT / "docs" / "debugging" / "conveyor.png").is_file()
    source = (ROOT / "docs" / "debugging" / "conveyor.asi").read_text()
    assert "        O   C 0             ; or the batch is complete" in source
