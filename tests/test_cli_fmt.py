"""``asictl fmt``: in place, --check, --diff, stdin, and files it must not touch."""

from __future__ import annotations

from pathlib import Path

from click.testing import CliRunner

from asictl.cli import main

UGLY = "[PROGRAM]\r\n A I 1.0 ; \x84\r\n = Q 2.0\r\n"  # CP850 ä in the comment, CR LF
PRETTY = "[PROGRAM]\r\n        A   I 1.0           ; \x84\r\n        =   Q 2.0\r\n"


def write(tmp_path: Path, name: str, data: str) -> Path:
    path = tmp_path / name
    path.write_bytes(data.encode("latin-1"))
    return path


def test_formats_in_place_keeping_bytes_and_line_ends(runner: CliRunner, tmp_path: Path):
    path = write(tmp_path, "u.asi", UGLY)
    result = runner.invoke(main, ["fmt", str(path)])
    assert result.exit_code == 0, result.stderr
    assert path.read_bytes() == PRETTY.encode("latin-1")
    assert f"reformatted {path}" in result.stderr
    assert "fmt: 1 file reformatted, 0 unchanged" in result.stderr
    again = runner.invoke(main, ["fmt", str(path)])
    assert again.exit_code == 0 and "0 files reformatted, 1 unchanged" in again.stderr


def test_check_lists_what_would_change_and_changes_nothing(runner: CliRunner, tmp_path: Path):
    ugly = write(tmp_path, "u.asi", UGLY)
    write(tmp_path, "p.fb", PRETTY)
    result = runner.invoke(main, ["fmt", "--check", str(tmp_path)])
    assert result.exit_code == 1
    assert f"would reformat {ugly}" in result.stderr
    assert "p.fb" not in result.stderr.replace("unchanged", "")
    assert ugly.read_bytes() == UGLY.encode("latin-1")
    assert runner.invoke(main, ["fmt", "--check", str(tmp_path / "p.fb")]).exit_code == 0


def test_diff_shows_the_change(runner: CliRunner, tmp_path: Path):
    path = write(tmp_path, "u.asi", UGLY)
    result = runner.invoke(main, ["fmt", "--diff", str(path)])
    assert result.exit_code == 0
    assert "-= Q 2.0" not in result.stdout and "- = Q 2.0\n" in result.stdout
    assert "+        =   Q 2.0\n" in result.stdout
    assert path.read_bytes() == UGLY.encode("latin-1")


def test_syntax_errors_are_reported_and_the_file_left_alone(runner: CliRunner, tmp_path: Path):
    path = write(tmp_path, "bad.asi", "[PROGRAM]\n  A\n")
    result = runner.invoke(main, ["fmt", str(path)])
    assert result.exit_code == 1
    assert f"{path}:2:4: error: expected a bit operand" in result.stderr
    assert "not formatted: it has syntax errors" in result.stderr
    assert path.read_text() == "[PROGRAM]\n  A\n"


def test_stdin_to_stdout_and_unreadable_files(runner: CliRunner, tmp_path: Path):
    result = runner.invoke(main, ["fmt", "-"], input=b"[PROGRAM]\n A I 1.0\n")
    assert result.exit_code == 0 and result.stdout == "[PROGRAM]\n        A   I 1.0\n"
    missing = runner.invoke(main, ["fmt", str(tmp_path / "none.asi")])
    assert missing.exit_code == 2 and "cannot read" in missing.stderr


def test_without_arguments_the_current_folder_as_check_finds_it(
    runner: CliRunner, tmp_path: Path, monkeypatch
):
    write(tmp_path, "u.asi", UGLY)
    (tmp_path / "sub").mkdir()
    write(tmp_path / "sub", "b.fb", UGLY)
    (tmp_path / ".hidden").mkdir()
    hidden = write(tmp_path / ".hidden", "h.asi", UGLY)
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(main, ["fmt", "--check"])
    assert result.exit_code == 1
    assert "would reformat u.asi" in result.stderr
    assert f"would reformat {Path('sub') / 'b.fb'}" in result.stderr
    assert "h.asi" not in result.stderr and hidden.read_bytes() == UGLY.encode("latin-1")


def test_mixed_line_ends_are_kept_line_by_line(runner: CliRunner, tmp_path: Path):
    """A file edited on DOS, Unix and an old Mac keeps each line's own end."""
    path = write(tmp_path, "m.asi", "[PROGRAM]\r\n A I 1.0\n = Q 2.0\r ***\r\n")
    result = runner.invoke(main, ["fmt", str(path)])
    assert result.exit_code == 0, result.stderr
    import re

    assert re.findall(rb"\r\n|\r|\n", path.read_bytes()) == [b"\r\n", b"\n", b"\r", b"\r\n"]
    assert b"        A   I 1.0" in path.read_bytes()
