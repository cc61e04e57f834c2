"""Odd file names and paths get a plain message and exit 1 or 2, never an internal error:
a name that is not UTF-8, an output behind a symbolic-link loop, a NUL in a scenario."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BLINK = (ROOT / "demos" / "blink.asi").read_bytes()


def asictl(tmp_path: Path, *args: str) -> subprocess.CompletedProcess[str]:
    done = subprocess.run(
        [sys.executable, "-m", "asictl", *args], cwd=tmp_path, capture_output=True, text=True,
        env={**os.environ, "ASICTL_STATE_DIR": str(tmp_path / "state")},
    )
    assert "internal error" not in done.stderr and "Traceback" not in done.stderr, done.stderr
    return done


@pytest.mark.parametrize("command", [["compile"], ["sim"], ["download"]])
def test_a_file_name_that_is_not_utf8(tmp_path: Path, command: list[str]):
    name = os.fsdecode(b"b\xff.asi")  # the str Python makes of such a name
    (tmp_path / name).write_bytes(BLINK)
    done = asictl(tmp_path, *command, name)
    assert done.returncode in (1, 2)
    assert "the file name is not UTF-8" in done.stderr and "b\\xff.asi" in done.stderr


@pytest.mark.parametrize("option", ["-o", "--listing"])
def test_an_output_behind_a_symlink_loop(tmp_path: Path, option: str):
    (tmp_path / "blink.asi").write_bytes(BLINK)
    (tmp_path / "loop1").symlink_to("loop2")
    (tmp_path / "loop2").symlink_to("loop1")
    args = ["compile", "blink.asi", option, "loop1"]
    if option == "--listing":
        args += ["-o", "out.hex"]
    done = asictl(tmp_path, *args)
    assert done.returncode == 2
    assert "loop1: cannot write: Too many levels of symbolic links" in done.stderr


def test_an_upload_behind_a_symlink_loop(tmp_path: Path):
    (tmp_path / "blink.asi").write_bytes(BLINK)
    assert asictl(tmp_path, "download", "blink.asi").returncode == 0
    (tmp_path / "loop1").symlink_to("loop2")
    (tmp_path / "loop2").symlink_to("loop1")
    done = asictl(tmp_path, "upload", "-o", "loop1")
    assert done.returncode == 2 and "Too many levels of symbolic links" in done.stderr


@pytest.mark.parametrize("command", ["sim", "test"])
def test_a_nul_in_a_scenarios_program(tmp_path: Path, command: str):
    (tmp_path / "blink.asi").write_bytes(BLINK)
    scenario = tmp_path / "nul.scenario.toml"
    scenario.write_text('program = "bl\\u0000ink.asi"\n[[step]]\nat_ms = 1\n')
    args = ["sim", "--scenario", str(scenario)] if command == "sim" else ["test", str(scenario)]
    done = asictl(tmp_path, *args)
    assert done.returncode == 2
    assert "program is a file name (not empty, no NUL characters)" in done.stderr
