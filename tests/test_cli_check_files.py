"""Which files ``asictl check`` checks: a project folder without its hidden folders and
build outputs, ``--exclude``, the current folder by default, and function-block files
through the programs that call them (as the pre-commit hook hands them over)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.cli import main

ROOT = Path(__file__).resolve().parent.parent
GOOD = "[PROGRAM]\n    A I 1.0\n    = Q 2.0\n"
BAD = "[PROGRAM]\n    A I 1.0\n    = Q 32.0\n"


def tree(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


@pytest.fixture
def project(tmp_path: Path) -> Path:
    """A project with one good program, and bad copies where tools keep theirs."""
    tree(tmp_path, {
        "src/main.asi": GOOD,
        "src/sub/other.ASI": GOOD,
        ".hidden/bad.asi": BAD,
        ".git/bad.asi": BAD,
        ".venv/lib/bad.asi": BAD,
        "build/bad.asi": BAD,
        "dist/bad.asi": BAD,
        "src/__pycache__/bad.asi": BAD,
    })
    return tmp_path


def test_check_dot_skips_hidden_folders_and_build_outputs(
    runner: CliRunner, project: Path, monkeypatch: pytest.MonkeyPatch
):
    monkeypatch.chdir(project)
    result = runner.invoke(main, ["check", "."])
    assert result.exit_code == 0, result.output
    assert "checked 2 files: 0 errors" in result.stderr
    assert "bad.asi" not in result.output


def test_without_arguments_check_checks_the_current_folder(
    runner: CliRunner, project: Path, monkeypatch: pytest.MonkeyPatch
):
    monkeypatch.chdir(project)
    (project / "src" / "broken.asi").write_text(BAD)
    result = runner.invoke(main, ["check"])
    assert result.exit_code == 1
    assert "src/broken.asi:3:7: error" in result.stderr
    assert "checked 3 files: 1 error" in result.stderr


def test_a_hidden_folder_named_on_the_command_line_is_checked(runner: CliRunner, project: Path):
    result = runner.invoke(main, ["check", str(project / ".hidden")])
    assert result.exit_code == 1 and "checked 1 file: 1 error" in result.stderr


def test_exclude_by_name_path_and_folder_repeatable(runner: CliRunner, project: Path):
    tree(project, {
        "src/old/broken.asi": BAD, "src/wip_draft.asi": BAD, "vendor/x/broken.asi": BAD,
    })
    everything = runner.invoke(main, ["check", str(project)])
    assert everything.exit_code == 1 and "checked 5 files: 3 errors" in everything.stderr
    result = runner.invoke(main, [
        "check", str(project), "--exclude", "old", "--exclude", "*_draft.asi",
        "--exclude", "vendor/*",
    ])
    assert result.exit_code == 0, result.output
    assert "checked 2 files: 0 errors" in result.stderr
    named = runner.invoke(main, ["check", str(project / "src/wip_draft.asi"),
                                 str(project / "src/main.asi"), "--exclude", "*_draft.asi"])
    assert named.exit_code == 0 and "checked 1 file" in named.stderr


def test_a_folder_with_no_programs_says_what_was_not_searched(runner: CliRunner, tmp_path: Path):
    tree(tmp_path, {"build/x.asi": GOOD})
    result = runner.invoke(main, ["check", str(tmp_path)])
    assert result.exit_code == 2
    assert "no .asi files" in result.stderr and "build outputs" in result.stderr


def test_a_file_named_twice_is_checked_once(runner: CliRunner, project: Path):
    main_file = str(project / "src" / "main.asi")
    result = runner.invoke(main, ["check", main_file, main_file, str(project / "src")])
    assert "checked 2 files" in result.stderr


# --------------------------------------------------------------- function-block files

CALLER = """[DECL]
Latch FB latch.fb

[PROGRAM]
    JU FB Latch
    A F 20.2
    = Q 2.0
"""
DECLARES_ONLY = "[DECL]\nLatch FB latch.fb\n\n[PROGRAM]\n    A I 1.0\n    = Q 2.0\n"
BAD_BLOCK = "[PROGRAM]\n    A F 20.0\n    = Q 32.0\n    BE\n"


def test_a_block_is_checked_through_the_programs_that_call_it(
    runner: CliRunner, tmp_path: Path
):
    tree(tmp_path, {
        "a.asi": CALLER, "b.asi": CALLER, "c.asi": DECLARES_ONLY, "latch.fb": BAD_BLOCK,
        "unrelated.asi": BAD,
    })
    block = str(tmp_path / "latch.fb")
    result = runner.invoke(main, ["check", block])
    assert result.exit_code == 1
    note = (f"{block}: checked through the programs that call it: {tmp_path / 'a.asi'}, "
            f"{tmp_path / 'b.asi'}")
    assert note in result.stderr
    assert f"{block}:3:7: error: slave address 32 out of range 0..31 [E201]" in result.stderr
    assert "unrelated.asi" not in result.stderr.replace(note, "")
    assert "checked 2 files" in result.stderr


def test_a_block_and_its_caller_together_are_one_check(runner: CliRunner, tmp_path: Path):
    """What the pre-commit hook passes when both changed."""
    tree(tmp_path, {"a.asi": CALLER, "latch.fb": "[PROGRAM]\n    A F 20.0\n    BE\n"})
    result = runner.invoke(main, ["check", str(tmp_path / "a.asi"), str(tmp_path / "latch.fb")])
    assert result.exit_code == 0, result.output
    assert "checked 1 file: 0 errors" in result.stderr


def test_a_block_nobody_calls_is_checked_on_its_own(runner: CliRunner, tmp_path: Path):
    tree(tmp_path, {"c.asi": DECLARES_ONLY, "latch.fb": BAD_BLOCK})
    block = str(tmp_path / "latch.fb")
    result = runner.invoke(main, ["check", block])
    assert result.exit_code == 1
    assert "checked through" not in result.stderr
    assert f"{block}:3:7: error" in result.stderr and "checked 1 file" in result.stderr


def test_the_demo_blocks_are_checked_through_fb_asi(runner: CliRunner):
    result = runner.invoke(main, ["check", "demos/latch.fb", "demos/count3.fb"])
    assert result.exit_code == 0, result.output
    assert "demos/latch.fb: checked through the programs that call it: demos/fb.asi" in (
        result.stderr
    )
    assert "checked 1 file" in result.stderr


def test_the_pre_commit_hook_matches_programs_and_blocks():
    text = (ROOT / ".pre-commit-hooks.yaml").read_text()
    pattern = re.search(r"^\s*files:\s*(\S+)\s*$", text, re.M)
    assert pattern, text
    files = re.compile(pattern.group(1))
    for name in ("a.asi", "LIB/MEAN.FB", "x/latch.fb", "B.ASI"):
        assert files.search(name), name
    for name in ("a.asi.bak", "fb.txt", "notes.md"):
        assert not files.search(name), name


def test_fmt_of_a_folder_leaves_hidden_folders_and_build_outputs_alone(
    runner: CliRunner, tmp_path: Path
):
    untidy = "[PROGRAM]\nA I 1.0\n= Q 2.0\n"
    tree(tmp_path, {"src/a.asi": untidy, "src/b.fb": untidy, ".venv/x.asi": untidy,
                    "build/y.fb": untidy})
    result = runner.invoke(main, ["fmt", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "src/a.asi").read_text() != untidy
    assert (tmp_path / "src/b.fb").read_text() != untidy
    assert (tmp_path / ".venv/x.asi").read_text() == untidy
    assert (tmp_path / "build/y.fb").read_text() == untidy
