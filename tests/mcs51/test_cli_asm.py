"""``asictl asm`` and ``asictl disasm`` as a user sees them: files, messages, exit codes."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from asictl.cli import main

PROGRAM = "start:\tmov a,#1\n\tsjmp start\n"


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_asm_writes_hex_next_to_the_source(runner, tmp_path):
    source = write(tmp_path, "prog.a51", PROGRAM)
    result = runner.invoke(main, ["asm", str(source)])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "prog.hex").read_text() == ":04000000740180FC0B\n:00000001FF\n"
    assert result.stderr == ""


def test_asm_writes_listing_and_symbols_where_asked(runner, tmp_path):
    source = write(tmp_path, "prog.a51", PROGRAM)
    out = tmp_path / "out"
    out.mkdir()
    result = runner.invoke(
        main,
        [
            "asm",
            str(source),
            "-o",
            str(out / "x.hex"),
            "--listing",
            str(out / "x.lst"),
            "--symbols",
            str(out / "x.sym"),
        ],
    )
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.iterdir()) == ["x.hex", "x.lst", "x.sym"]
    assert "0002  80 FC          2      2  \tsjmp start" in (out / "x.lst").read_text()
    assert (out / "x.sym").read_text().splitlines()[1].split() == ["start", "0000", "label"]
    assert not (tmp_path / "prog.hex").exists()


def test_asm_errors_go_to_stderr_with_caret_and_write_nothing(runner, tmp_path):
    source = write(tmp_path, "bad.a51", "\tnop\n\tmov a,#300\n\tljmp nowhere\n")
    result = runner.invoke(main, ["asm", str(source), "--listing", str(tmp_path / "bad.lst")])
    assert result.exit_code == 1
    lines = result.stderr.splitlines()
    assert lines[:3] == [
        f"{source}:2:9: error: value 12Ch is out of range for #data (-128..0FFh) [E504]",
        "  \tmov a,#300".expandtabs(1),
        "          ^~~",
    ]
    assert f"{source}:3:7: error: undefined symbol 'nowhere' [E507]" in lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.a51"]


def test_asm_warnings_are_shown_but_do_not_fail(runner, tmp_path):
    source = write(tmp_path, "w.a51", "\tsetb p1\n")
    result = runner.invoke(main, ["asm", str(source)])
    assert result.exit_code == 0
    assert "w.a51:1:7: warning: 'p1' is a byte address" in result.stderr
    assert (tmp_path / "w.hex").exists()


def test_asm_reports_errors_in_included_files_with_their_source(runner, tmp_path):
    write(tmp_path, "defs.inc", "\tdb 1,\n")
    source = write(tmp_path, "main.a51", "\t.inc defs.inc\n")
    result = runner.invoke(main, ["asm", str(source)])
    assert result.exit_code == 1
    assert result.stderr.splitlines()[1:] == ["  \tdb 1,".expandtabs(1), "       ^"]


def test_asm_unreadable_file_exits_2(runner, tmp_path):
    result = runner.invoke(main, ["asm", str(tmp_path / "missing.a51")])
    assert result.exit_code == 2
    assert "missing.a51: cannot read" in result.stderr


def test_asm_from_stdin_needs_an_output_name(runner, tmp_path):
    result = runner.invoke(main, ["asm", "-"], input=PROGRAM)
    assert result.exit_code == 2
    assert "needs -o" in result.stderr
    out = tmp_path / "in.hex"
    result = runner.invoke(main, ["asm", "-", "-o", str(out)], input=PROGRAM)
    assert result.exit_code == 0, result.output
    assert out.read_text().startswith(":04000000")


def test_disasm_prints_source_that_reassembles(runner, tmp_path):
    source = write(tmp_path, "prog.a51", PROGRAM)
    runner.invoke(main, ["asm", str(source)])
    result = runner.invoke(main, ["disasm", str(tmp_path / "prog.hex")])
    assert result.exit_code == 0, result.output
    assert result.stdout.splitlines() == [
        "        ORG     0000h",
        "L0000:  MOV     A,#01h",
        "        SJMP    L0000",
    ]
    again = write(tmp_path, "again.a51", result.stdout)
    assert runner.invoke(main, ["asm", str(again)]).exit_code == 0
    assert (tmp_path / "again.hex").read_text() == (tmp_path / "prog.hex").read_text()


def test_disasm_to_file(runner, tmp_path):
    image = write(tmp_path, "p.hex", ":0100000000FF\n:00000001FF\n")
    result = runner.invoke(main, ["disasm", str(image), "-o", str(tmp_path / "p.a51")])
    assert result.exit_code == 0
    assert result.stdout == ""
    assert (tmp_path / "p.a51").read_text().splitlines()[-1].strip() == "NOP"


def test_disasm_does_not_write_over_a_source_unless_forced(runner, tmp_path):
    image = write(tmp_path, "p.hex", ":0100000000FF\n:00000001FF\n")
    source = write(tmp_path, "p.a51", "start: NOP ; the hand-written source\n")
    result = runner.invoke(main, ["disasm", str(image), "-o", str(source)])
    assert result.exit_code == 2
    assert "exists; not overwritten (use --force)" in result.stderr
    assert source.read_text() == "start: NOP ; the hand-written source\n"
    assert runner.invoke(main, ["disasm", str(image), "-o", str(source), "--force"]).exit_code == 0
    assert source.read_text().splitlines()[-1].strip() == "NOP"


@pytest.mark.parametrize(
    "content", [None, "this is no hex\n", ":020000040001F9\n:0100000000FF\n:00000001FF\n"]
)
def test_disasm_bad_input_exits_2(runner, tmp_path, content):
    path = tmp_path / "x.hex"
    if content is not None:
        path.write_text(content)
    result = runner.invoke(main, ["disasm", str(path)])
    assert result.exit_code == 2
    assert result.stderr.startswith("asictl: error: ")


def test_help_explains_exit_status(runner):
    for command in ("asm", "disasm"):
        result = runner.invoke(main, [command, "--help"])
        assert result.exit_code == 0
        assert "Exit status" in result.output


def test_output_files_get_ordinary_permissions(runner, tmp_path):
    source = write(tmp_path, "prog.a51", PROGRAM)
    old_umask = os.umask(0o022)
    try:
        assert runner.invoke(main, ["asm", str(source)]).exit_code == 0
    finally:
        os.umask(old_umask)
    assert (tmp_path / "prog.hex").stat().st_mode & 0o777 == 0o644
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []
