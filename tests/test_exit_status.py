"""One exit status for a program with errors: every command that reads a program exits 1
on one, as ``check`` does, and docs/commands.md's "Exit status" names those commands."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.cli import main

ROOT = Path(__file__).resolve().parent.parent
BAD = "[PROGRAM]\n    A I 1.0\n    XYZ Q 2.0\n"


def _documented() -> list[str]:
    """The commands the docs say exit 1 on a program with errors."""
    text = (ROOT / "docs" / "commands.md").read_text()
    section = text.split("## Exit status", 1)[1].split("\n## ", 1)[0]
    listed = re.search(r"every command that reads a program \(([^)]*)\)", section, re.S)
    assert listed, "docs/commands.md's Exit status lists the commands that read a program"
    return re.findall(r"`(\w+)`", listed[1])


#: each command's arguments around the program file (scenario and properties beside it)
CALLS = {
    "check": ["check", "bad.asi"], "xref": ["xref", "bad.asi"], "fmt": ["fmt", "bad.asi"],
    "compile": ["compile", "bad.asi"], "download": ["download", "bad.asi"],
    "verify": ["verify", "bad.asi"], "setup": ["setup", "bad.asi"],
    "sim": ["sim", "bad.asi"], "test": ["test", "bad.scenario.toml"],
    "mutate": ["mutate", "bad.scenario.toml"], "debug": ["debug", "bad.asi", "--batch", "-"],
    "prove": ["prove", "bad.props.toml"], "diff": ["diff", "bad.asi", "bad.asi"],
    "export": ["export", "--to", "st", "bad.asi"],
}


def test_the_docs_name_every_command_the_test_runs():
    assert sorted(_documented()) == sorted(CALLS)


@pytest.mark.parametrize("command", sorted(CALLS))
def test_a_program_with_errors_exits_1_with_its_diagnostics(
    command: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, runner: CliRunner,
) -> None:
    if command == "prove":
        pytest.importorskip("z3")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("ASICTL_STATE_DIR", str(tmp_path / "state"))
    Path("bad.asi").write_text(BAD)
    Path("bad.scenario.toml").write_text('program = "bad.asi"\n[[step]]\nat = "0ms"\n')
    Path("bad.props.toml").write_text('program = "bad.asi"\n')
    assert runner.invoke(main, ["download", str(ROOT / "demos" / "blink.asi")]).exit_code == 0
    result = runner.invoke(main, CALLS[command], input="")
    assert result.exit_code == 1, result.output
    assert "bad.asi:3:5: error: unknown instruction 'XYZ' [E104]" in result.stderr
