"""``asictl check`` as a user and a CI system see it: output formats and exit codes."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from asictl.cli import main

BAD = "[PROGRAM]\n    A I 1.0\n    = Q 32.0\n    L KT 505\n"


def write(tmp_path: Path, name: str, text: str) -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_clean_file_exits_0(runner: CliRunner):
    result = runner.invoke(main, ["check", "demos/blink.asi"])
    assert result.exit_code == 0, result.output
    assert "checked 1 file: 0 errors, 0 warnings" in result.stderr


def test_errors_exit_1_with_location_source_line_and_caret(runner: CliRunner, tmp_path: Path):
    path = write(tmp_path, "bad.asi", BAD)
    result = runner.invoke(main, ["check", path])
    assert result.exit_code == 1
    lines = result.stderr.splitlines()
    first = lines.index(f"{path}:3:7: error: slave address 32 out of range 0..31 [E201]")
    assert lines[first + 1] == "      = Q 32.0"
    assert lines[first + 2] == "        ^~~~~~"
    assert f"{path}:4:7: warning: timers count in 10 ms steps" in result.stderr
    assert "checked 1 file: 1 error, 1 warning" in result.stderr


def test_werror_makes_warnings_fail(runner: CliRunner, tmp_path: Path):
    path = write(tmp_path, "w.asi", "[PROGRAM]\n    L KT 505\n")
    assert runner.invoke(main, ["check", path]).exit_code == 0
    assert runner.invoke(main, ["check", "--werror", path]).exit_code == 1


def test_json_format(runner: CliRunner, tmp_path: Path):
    path = write(tmp_path, "bad.asi", BAD)
    result = runner.invoke(main, ["check", "--format", "json", path])
    assert result.exit_code == 1
    items = json.loads(result.stdout)
    assert items[0] == {
        "file": path, "line": 3, "column": 7, "severity": "error", "code": "E201",
        "message": "slave address 32 out of range 0..31",
    }
    assert items[1]["severity"] == "warning"


def test_github_format(runner: CliRunner, tmp_path: Path):
    path = write(tmp_path, "bad.asi", BAD)
    result = runner.invoke(main, ["check", "--format", "github", path])
    lines = result.stdout.splitlines()
    assert lines[0].startswith(f"::error file={path},line=3,col=7,title=E201::slave address 32")
    assert lines[1].startswith("::warning ")


def test_stdin(runner: CliRunner):
    result = runner.invoke(main, ["check", "-"], input=BAD)
    assert result.exit_code == 1
    assert "<stdin>:3:7: error:" in result.stderr


def test_all_errors_of_all_files_in_one_run(runner: CliRunner, tmp_path: Path):
    a = write(tmp_path, "a.asi", BAD)
    b = write(tmp_path, "b.asi", "[PROGRAM]\n    A I 40.0\n    = Q 1.0\n")
    result = runner.invoke(main, ["check", a, b])
    assert f"{a}:3:7: error" in result.stderr
    assert f"{b}:2:7: error" in result.stderr
    assert "checked 2 files: 2 errors, 1 warning" in result.stderr


def test_unreadable_file_exits_2_but_others_are_checked(runner: CliRunner, tmp_path: Path):
    a = write(tmp_path, "a.asi", BAD)
    result = runner.invoke(main, ["check", str(tmp_path / "missing.asi"), a])
    assert result.exit_code == 2
    assert "missing.asi: cannot read" in result.stderr
    assert f"{a}:3:7: error" in result.stderr
    assert "Traceback" not in result.output


def test_directory_means_its_asi_files(runner: CliRunner, tmp_path: Path):
    write(tmp_path, "a.asi", BAD)
    write(tmp_path, "notes.txt", "not a program")
    result = runner.invoke(main, ["check", str(tmp_path)])
    assert result.exit_code == 1
    assert "checked 1 file" in result.stderr


def test_dialect_control1(runner: CliRunner, tmp_path: Path):
    path = write(tmp_path, "c.asi", "[PROGRAM]\n    L KB 3\n    T FY 1\n")
    assert runner.invoke(main, ["check", path]).exit_code == 0
    result = runner.invoke(main, ["check", "--dialect", "control1", path])
    assert result.exit_code == 1
    assert "AS-i Control II only" in result.stderr


def test_usage_error_exits_2(runner: CliRunner):
    assert runner.invoke(main, ["check", "--format", "xml", "x.asi"]).exit_code == 2


def test_dos_file_is_read_without_complaint(runner: CliRunner, tmp_path: Path):
    path = tmp_path / "dos.asi"
    path.write_bytes(
        b"; Z\x84hler f\x81r Eing\x84nge\r\n[PROGRAM]\r\n    A I 1.0 ; \xe4\r\n    = Q 2.0\r\n\x1a"
    )
    result = runner.invoke(main, ["check", str(path)])
    assert result.exit_code == 0, result.stderr


def test_pre_commit_hook_runs_asictl_check():
    text = Path(".pre-commit-hooks.yaml").read_text()
    assert "id: asictl-check" in text
    assert "entry: asictl check" in text
