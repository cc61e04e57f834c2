"""``asictl export``: the files it writes, the process-image map, what it leaves for a
person, and bad input."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from click.testing import CliRunner

from asictl.build import build_file
from asictl.cli import main
from asictl.export.awl import export_awl

DEMOS = Path(__file__).parents[2] / "demos"


def _demo(tmp_path: Path, name: str) -> Path:
    for path in DEMOS.glob(Path(name).stem + ".*"):
        shutil.copy(path, tmp_path)
    for block in DEMOS.glob("*.fb"):
        shutil.copy(block, tmp_path)
    return tmp_path / name


def test_the_awl_and_its_map_are_written_beside_each_other(tmp_path: Path) -> None:
    source = _demo(tmp_path, "sequence.asi")
    out = tmp_path / "plant.awl"
    result = CliRunner().invoke(main, ["export", str(source), "--to", "awl", "-o", str(out)])
    assert result.exit_code == 0, result.output
    text = out.read_text()
    assert "ORGANIZATION_BLOCK OB 1" in text and "TODO" not in text
    operands = json.loads((tmp_path / "plant.map.json").read_text())["operands"]
    # the master's packing: slave 2n in the low nibble of byte n, flags keep their numbers
    assert operands["I 1.0"] == "I 0.4"
    assert operands["I 1.3"] == "I 0.7"
    assert operands["Q 2.0"] == "Q 1.0"
    assert operands["F 0.2"] == "M 0.2"
    assert len(operands) == 10


def test_every_operand_kind_has_its_place() -> None:
    program = build_file(DEMOS / "edge.asi").program
    assert program is not None
    operands = export_awl("edge.asi", program).operands
    assert operands["FY 11"] == "MB 11"
    assert operands["F 10.3"] == "M 10.3"
    program = build_file(DEMOS / "fb.asi").program
    assert program is not None
    operands = export_awl("fb.asi", program).operands
    assert operands["PSeg 4"] == "DB1.DBB 68"
    assert operands["I2 1.2"] == "DB1.DBX 32.6"


def test_what_has_no_equivalent_is_listed_with_its_line_and_exit_1(tmp_path: Path) -> None:
    source = _demo(tmp_path, "fb.asi")
    result = CliRunner().invoke(main, ["export", str(source), "--to", "awl"])
    assert result.exit_code == 1
    left = [line for line in result.stderr.splitlines() if line.endswith("left for a person")]
    assert [line.split(": ")[0] for line in left] == [f"{source}:44", f"{source}:63"]
    assert "GetLAS" in left[0] and "SetPP" in left[1]
    text = source.with_suffix(".awl").read_text()
    assert text.count("TODO: finish by hand") == 2


def test_stdout_gets_the_awl_alone(tmp_path: Path) -> None:
    source = _demo(tmp_path, "logic.asi")
    result = CliRunner().invoke(main, ["export", str(source), "--to", "awl", "-o", "-"])
    assert result.exit_code == 0
    assert result.stdout.startswith("// logic.asi: exported by asictl")
    assert not list(tmp_path.glob("*.json"))


def test_a_program_with_errors_is_refused_and_nothing_written(tmp_path: Path) -> None:
    source = tmp_path / "bad.asi"
    source.write_text("[PROGRAM]\n  A I 99.0\n  = Q 2.0\n")
    result = CliRunner().invoke(main, ["export", str(source), "--to", "awl"])
    assert result.exit_code == 1
    assert f"{source}:2:" in result.stderr and "error" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.asi"]


def test_an_unknown_format_lists_the_formats(tmp_path: Path) -> None:
    source = _demo(tmp_path, "logic.asi")
    result = CliRunner().invoke(main, ["export", str(source), "--to", "scl"])
    assert result.exit_code == 2
    assert "'awl'" in result.stderr


def test_a_missing_folder_writes_nothing(tmp_path: Path) -> None:
    source = _demo(tmp_path, "logic.asi")
    out = tmp_path / "missing" / "logic.awl"
    result = CliRunner().invoke(main, ["export", str(source), "--to", "awl", "-o", str(out)])
    assert result.exit_code == 2
    assert "cannot write" in result.stderr
    assert not out.parent.exists()


def test_the_programs_names_go_into_the_map_and_the_symbol_table(tmp_path: Path) -> None:
    source = _demo(tmp_path, "fb.asi")
    (tmp_path / "fb.symbols.toml").write_text('Start = "I 1.0"\nLamp = "Q 2.0"\n')
    CliRunner().invoke(main, ["export", str(source), "--to", "awl"])
    operands = json.loads((tmp_path / "fb.map.json").read_text())["operands"]
    assert operands["Start"] == operands["I 1.0"] == "I 0.4"
    rows = (tmp_path / "fb.sym.csv").read_text().splitlines()
    assert '"Latch";"FC 1";"FC 1";"function block Latch"' in rows
    assert '"Lamp";"Q 1.0";"BOOL";"Q 2.0"' in rows


def test_flags_the_host_writes_are_left_for_a_person_in_every_language(tmp_path: Path) -> None:
    source = tmp_path / "panel.asi"
    source.write_text("; asictl: host F 10.0    ; the operator panel's start request\n"
                      "[PROGRAM]\n  A F 10.0\n  = Q 2.0\n")
    for to, where in (("awl", "M 10.0"), ("st", "F10_0")):
        result = CliRunner().invoke(main, ["export", str(source), "--to", to])
        assert result.exit_code == 1, result.output
        assert f"{source}:1: F 10.0 is written by the host" in result.stderr
        assert f"connect that writer to {where}: left for a person" in result.stderr
        assert f"TODO: {source}:1: F 10.0" in source.with_suffix(f".{to}").read_text()


def test_an_image_exports_from_the_source_it_carries_and_not_without(tmp_path: Path) -> None:
    source = _demo(tmp_path, "logic.asi")
    runner = CliRunner()
    with_source, without = tmp_path / "with.hex", tmp_path / "without.hex"
    assert runner.invoke(main, ["compile", str(source), "-o", str(with_source)]).exit_code == 0
    assert runner.invoke(main, ["compile", str(source), "-o", str(without),
                                "--no-source"]).exit_code == 0
    result = runner.invoke(main, ["export", str(with_source), "--to", "awl", "-o", "-"])
    assert result.exit_code == 0, result.output
    assert "A     I 0.4" in result.stdout
    result = runner.invoke(main, ["export", str(without), "--to", "awl"])
    assert result.exit_code == 2
    assert "no IL program text to export" in result.stderr
