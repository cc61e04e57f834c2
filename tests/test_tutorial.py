"""docs/tutorial.md cannot rot: every command in it runs, in order, in a fresh folder,
and must exit as the text says and print the lines it shows.

The tutorial's ``console`` blocks hold ``$ command`` lines, each followed by the output
it shows (``...`` stands for anything; a line ``...`` for lines left out); ``# exit
status N`` after a command is its expected exit status (else 0). Blocks titled
``title=NAME`` are files the reader saves: the test writes them when it reaches them.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TUTORIAL = ROOT / "docs" / "tutorial.md"
_BLOCK = re.compile(r"^```(\S*)([^\n]*)\n(.*?)^```$", re.M | re.S)
_EXIT = re.compile(r"#\s*exit status (\d+)\s*$")


@dataclass
class Command:
    line: str
    exit_status: int = 0
    shows: list[str] = field(default_factory=list)


def steps() -> list[tuple[str, str] | Command]:
    """The files to write and the commands to run, in the tutorial's order."""
    out: list[tuple[str, str] | Command] = []
    for match in _BLOCK.finditer(TUTORIAL.read_text()):
        language, info, body = match.groups()
        title = re.search(r"title=(\S+)", info)
        if title:
            out.append((title.group(1), body))
        elif language == "console":
            for line in body.splitlines():
                if line.startswith("$ "):
                    command = line[2:]
                    status = _EXIT.search(command)
                    out.append(Command(command, int(status.group(1)) if status else 0))
                elif out and isinstance(out[-1], Command):
                    out[-1].shows.append(line)
    return out


def _pattern(shown: str) -> re.Pattern[str]:
    return re.compile(".*".join(re.escape(part) for part in shown.rstrip().split("...")))


def test_the_tutorial_has_what_it_promises():
    commands = [s.line for s in steps() if isinstance(s, Command)]
    for verb in ("check", "compile", "download", "start", "status", "upload", "sim", "test"):
        assert any(c.startswith(f"asictl {verb}") for c in commands), verb
    assert any("--plot" in c for c in commands)
    assert "docs/tutorial.md" in (ROOT / "README.md").read_text()
    assert (ROOT / "docs" / "tutorial" / "stairs.png").is_file()


def test_every_command_runs_and_shows_what_the_text_says(tmp_path: Path):
    folder = tmp_path / "work"
    folder.mkdir()
    env = {**os.environ, "ASICTL_STATE_DIR": str(tmp_path / "state"), "ASICTL_PY": sys.executable}
    prelude = 'asictl() { "$ASICTL_PY" -m asictl "$@"; }\n'
    for step in steps():
        if isinstance(step, tuple):
            name, text = step
            (folder / name).write_text(text)
            continue
        result = subprocess.run(
            ["bash", "-c", prelude + step.line], cwd=folder, env=env, capture_output=True,
            text=True, timeout=120,
        )
        output = (result.stdout + result.stderr).splitlines()
        assert result.returncode == step.exit_status, (step.line, result.stdout, result.stderr)
        for shown in step.shows:
            if shown.strip() == "...":
                continue
            pattern = _pattern(shown)
            assert any(pattern.fullmatch(line.rstrip()) for line in output), (
                f"'{step.line}' does not show {shown!r}; it printed:\n" + "\n".join(output)
            )
    assert (folder / "stairs.png").read_bytes().startswith(b"\x89PNG")


def test_the_wildcard_stands_for_anything_and_the_rest_must_match():
    pattern = _pattern("stairs.hex: ... bytes, identity ...")
    assert pattern.fullmatch("stairs.hex: 46 bytes of code, image 543 bytes, identity 0f")
    assert not pattern.fullmatch("stairs.hex: 46 bytes of code")
    assert not pattern.fullmatch("x stairs.hex: 46 bytes, identity 0f")
    assert _pattern("a.b (c)").fullmatch("a.b (c)") and not _pattern("a.b").fullmatch("axb")
