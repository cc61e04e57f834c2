"""``asictl xref``, the listing's cross-reference, and the command line's hints and colour."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.cli import main
from asictl.cli.terminal import stderr_colour

PROGRAM = (
    "[SETUP]\n"  # 1
    "1: iiii, 0\n"  # 2
    "2: oooo, 0\n"  # 3
    "[DECL]\n"  # 4
    "Reading BYTE 4\n"  # 5
    "[PROGRAM]\n"  # 6
    "        A   I 1.0\n"  # 7
    "        =   Q 2.0\n"  # 8
    "        JC  = skip\n"  # 9
    "***\n"  # 10
    "        A   I 1.1\n"  # 11
    "        T   Reading 2\n"  # 12
    "        =   Q 2.0\n"  # 13
    "skip:   L   Reading 2\n"  # 14
    "        T   FY 3\n"  # 15
    "        A   F 3.2\n"  # 16
    "        JU  FB GetLAS\n"  # 17
)


def write(tmp_path: Path, name: str, text: str) -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def rows(output: str, operand: str) -> list[str]:
    return [line for line in output.splitlines() if line.startswith(operand + " ")]


def test_xref_lists_each_operands_reads_and_writes(runner: CliRunner, tmp_path: Path):
    path = write(tmp_path, "p.asi", PROGRAM)
    result = runner.invoke(main, ["xref", path])
    assert result.exit_code == 0, result.output
    out = result.stdout
    assert rows(out, "Q 2.0") == [
        f"Q 2.0{' ' * 18}write     {path}:8 =, {path}:13 ="]
    assert [r.split()[2:] for r in rows(out, "I 1.1")] == [["read", f"{path}:11", "A"]]
    reading = [r.split()[3:] for r in rows(out, "Reading (XDATA")]
    assert reading == [["declared", f"{path}:5", "BYTE"], ["read", f"{path}:14", "L"],
                       ["write", f"{path}:12", "T"]]
    assert rows(out, "GetLAS (firmware)")[0].split()[2:] == ["used", f"{path}:17", "JU"]
    order = [line.split("  ")[0] for line in out.splitlines()[2:]]
    assert order.index("I 1.0") < order.index("Q 2.0") < order.index("F 3.2") < order.index(
        "FY 3") < order.index("skip") < order.index("GetLAS (firmware)")


def test_the_issues_example_q_at_7_and_11_and_i_at_9(runner: CliRunner, tmp_path: Path):
    lines = ["[SETUP]", "1: iiii, 0", "2: oooo, 0", "[PROGRAM]", "    A I 1.0", "    O I 1.2",
             "    = Q 2.0", "***", "    A I 1.1", "    O I 1.0", "    = Q 2.0"]
    path = write(tmp_path, "issue.asi", "\n".join(lines) + "\n")
    out = runner.invoke(main, ["xref", path]).stdout
    assert f"{path}:7 =, {path}:11 =" in rows(out, "Q 2.0")[0]
    assert f"{path}:9 A" in rows(out, "I 1.1")[0]


def test_json(runner: CliRunner, tmp_path: Path):
    path = write(tmp_path, "p.asi", PROGRAM)
    result = runner.invoke(main, ["xref", "--format", "json", path])
    [document] = json.loads(result.stdout)
    assert document["program"] == path
    by_operand = {o["operand"]: o for o in document["operands"]}
    assert by_operand["Q 2.0"]["kind"] == "operand"
    assert [(r["access"], r["line"], r["mark"]) for r in by_operand["Q 2.0"]["references"]] == [
        ("write", 8, "="), ("write", 13, "=")]
    assert by_operand["Reading"]["about"].startswith("XDATA ")


def test_modbus_table(runner: CliRunner, tmp_path: Path):
    path = write(tmp_path, "p.asi", PROGRAM)
    out = runner.invoke(main, ["xref", "--modbus", path]).stdout
    assert rows(out, "Q 2.0")[0].split(None, 2)[2].startswith("coil 8;")
    assert "holding register 403 bit 2" in rows(out, "F 3.2")[0]
    assert "discrete input 5" in rows(out, "I 1.1")[0]
    assert not rows(out, "Reading")  # the program's own memory
    result = runner.invoke(main, ["xref", "--modbus", "--format", "json", path])
    modbus = {m["operand"]: m["modbus"] for m in json.loads(result.stdout)[0]["modbus"]}
    assert modbus["FY 3"][0] == "holding register 403"


def test_several_files_and_a_program_with_errors(runner: CliRunner, tmp_path: Path):
    good = write(tmp_path, "good.asi", PROGRAM)
    bad = write(tmp_path, "bad.asi", "[PROGRAM]\n    A I 40.0\n")
    result = runner.invoke(main, ["xref", good, bad, "demos/blink.asi"])
    assert result.exit_code == 1
    assert f"; {good}" in result.stdout and "; demos/blink.asi" in result.stdout
    assert f"{bad}:2:7: error: slave address 40 out of range" in result.stderr


def test_an_image_cross_references_the_source_it_carries(runner: CliRunner, tmp_path: Path):
    image = str(tmp_path / "blink.hex")
    assert runner.invoke(main, ["compile", "demos/blink.asi", "-o", image]).exit_code == 0
    out = runner.invoke(main, ["xref", image]).stdout
    assert rows(out, "T 0")[0].split()[2:] == ["read", "blink.asi:11", "A"]
    bare = str(tmp_path / "bare.hex")
    runner.invoke(main, ["compile", "demos/blink.asi", "-o", bare, "--no-source"])
    result = runner.invoke(main, ["xref", bare])
    assert result.exit_code == 2 and "no IL source" in result.stderr


def test_the_listing_ends_with_the_cross_reference(runner: CliRunner, tmp_path: Path):
    listing = tmp_path / "fb.lst"
    result = runner.invoke(main, ["compile", "demos/fb.asi", "-o", str(tmp_path / "fb.hex"),
                                  "--listing", str(listing)])
    assert result.exit_code == 0, result.output
    text = listing.read_text()
    tail = text[text.index("; ---- cross-reference"):].splitlines()
    assert "; F 20.2             write     demos/latch.fb:9 S, demos/latch.fb:12 R" in tail
    assert "; Latch              defined   demos/latch.fb:1 file" in tail


def test_an_unknown_command_names_the_closest(runner: CliRunner):
    result = runner.invoke(main, ["chek", "demos/blink.asi"])
    assert result.exit_code == 2
    assert "No such command 'chek'. Did you mean 'check'?" in result.stderr
    assert "Did you mean" not in runner.invoke(main, ["zzzz"]).stderr


def test_check_reports_the_analyses_and_werror_counts_them(runner: CliRunner, tmp_path: Path):
    path = write(tmp_path, "w.asi", "[SETUP]\n1: iiii, 0\n[PROGRAM]\n    A I 1.0\n    = Q 1.0\n")
    result = runner.invoke(main, ["check", path])
    assert result.exit_code == 0 and "[W701]" in result.stderr
    assert f"{path}:1:1: note: slave 1 is set up here as iiii (0h)" not in result.stderr
    assert f"{path}:2:1: note: slave 1 is set up here as iiii (0h)" in result.stderr
    assert runner.invoke(main, ["check", "--werror", path]).exit_code == 1
    assert runner.invoke(main, ["check", "--werror", "demos/"]).exit_code == 0


@pytest.mark.parametrize(("tty", "no_color", "wanted"),
                         [(True, "", True), (True, "1", False), (False, "", False)])
def test_colour_only_on_a_terminal_without_no_color(
    monkeypatch: pytest.MonkeyPatch, tty: bool, no_color: str, wanted: bool
):
    class Stream:
        def isatty(self) -> bool:
            return tty

    monkeypatch.setattr("sys.stderr", Stream())
    monkeypatch.setenv("NO_COLOR", no_color)
    assert stderr_colour() is wanted


def test_check_and_compile_colour_their_diagnostics_on_a_terminal(
    runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    path = write(tmp_path, "bad.asi", "[PROGRAM]\n    A I 40.0\n")
    for module in ("asictl.cli.check", "asictl.cli.compile"):
        monkeypatch.setattr(f"{module}.stderr_colour", lambda: True)
    for command in (["check", path], ["compile", path]):
        coloured = runner.invoke(main, command, color=True).stderr
        assert "\x1b[1;31merror:\x1b[0m" in coloured
    assert "\x1b[" not in runner.invoke(main, ["check", path]).stderr  # not a terminal


def test_a_folder_or_no_argument_means_the_programs_below_it(
    runner: CliRunner, tmp_path: Path, monkeypatch
):
    write(tmp_path, "one.asi", PROGRAM)
    (tmp_path / "more").mkdir()
    write(tmp_path / "more", "two.asi", PROGRAM.replace("Q 2.0", "Q 2.1"))
    by_folder = runner.invoke(main, ["xref", str(tmp_path), "--format", "json"])
    assert by_folder.exit_code == 0, by_folder.stderr
    names = [Path(d["program"]).name for d in json.loads(by_folder.stdout)]
    assert names == ["one.asi", "two.asi"]
    monkeypatch.chdir(tmp_path)
    here = runner.invoke(main, ["xref"])
    assert here.exit_code == 0 and "; one.asi" in here.stdout
    assert f"; {Path('more') / 'two.asi'}" in here.stdout


def test_a_closed_pipe_is_no_internal_error(tmp_path: Path):
    """``asictl xref | head -1``: the reader goes away, asictl stops quietly."""
    import subprocess
    import sys

    for n in range(30):
        write(tmp_path, f"p{n:02}.asi", PROGRAM)
    shell = f"{sys.executable} -m asictl xref {tmp_path} | head -1; exit ${{PIPESTATUS[0]}}"
    done = subprocess.run(["bash", "-c", shell], capture_output=True, text=True)
    assert "internal error" not in done.stderr and "Traceback" not in done.stderr
    assert done.returncode in (0, 1)
    assert done.stdout.startswith("; ")
