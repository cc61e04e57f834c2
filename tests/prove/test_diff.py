"""``asictl diff`` and ``asictl.prove.equivalent``: network by network, and behaviour.

A refactored program (a latch moved in front, its labels renamed, an AND's operands
swapped) is proved equivalent; a changed one is told apart by a scenario that passes on
the old program and fails on the new one under the simulator."""

from __future__ import annotations

from pathlib import Path

from replay import passes

from asictl.build import build_file
from asictl.cli import main
from asictl.il.networks import compare
from asictl.prove import equivalent

OLD = """[SETUP]
1: iiii, 0
2: oooo, 0
[PROGRAM]
        A   I 1.0
        AN  I 1.2
        =   Q 2.0
***
        A   I 1.1
        JC  =latch
        JU  =keep
latch:  S   F 10.0
keep:   A   I 1.2
        R   F 10.0
***
        A   F 10.0
        =   Q 2.1
***
"""

#: The same behaviour: the latch first, its labels renamed, the AND's operands swapped.
REFACTORED = """[SETUP]
1: iiii, 0
2: oooo, 0
[PROGRAM]
        A   I 1.1
        JC  =set
        JU  =clear
set:    S   F 10.0
clear:  A   I 1.2
        R   F 10.0
***
        AN  I 1.2
        A   I 1.0
        =   Q 2.0
***
        A   F 10.0
        =   Q 2.1
***
"""

CHANGED = REFACTORED.replace("        AN  I 1.2\n        A   I 1.0", "        AN  I 1.3\n"
                             "        A   I 1.0")


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _program(path: Path):
    built = build_file(path)
    assert built.program is not None
    return built.program


def test_networks_are_paired_with_renamed_labels_and_moves_recognised(tmp_path: Path):
    old = _program(_write(tmp_path, "old.asi", OLD))
    new = _program(_write(tmp_path, "new.asi", REFACTORED))
    kinds = {(c.old.index if c.old else None, c.new.index if c.new else None): c.kind
             for c in compare(old, new)}
    assert kinds == {(2, 1): "renamed", (1, 2): "changed", (3, 3): "same"}


def test_a_refactored_program_is_equivalent(tmp_path: Path):
    old = _program(_write(tmp_path, "old.asi", OLD))
    new = _program(_write(tmp_path, "new.asi", REFACTORED))
    result = equivalent(old, new, timeout_s=300)
    assert result.verdict == "equivalent"
    assert result.trace is None


def test_a_changed_program_is_told_apart_by_a_scenario(tmp_path: Path, runner):
    old = _write(tmp_path, "old.asi", OLD)
    new = _write(tmp_path, "new.asi", CHANGED)
    assert equivalent(_program(old), _program(new), timeout_s=300).verdict == "different"
    result = runner.invoke(main, ["diff", str(old), str(new), "--equivalent", "--timeout", "300s"])
    assert result.exit_code == 1, result.output
    assert "different after cycle" in result.output
    scenario_path = tmp_path / "new.differs.scenario.toml"
    assert scenario_path.is_file()
    assert passes(scenario_path, old, new) == {"old.asi": True, "new.asi": False}


def test_the_command_line_without_equivalent(tmp_path: Path, runner):
    old = _write(tmp_path, "old.asi", OLD)
    same = _write(tmp_path, "same.asi", OLD.replace("latch", "hold"))
    result = runner.invoke(main, ["diff", str(old), str(same)])
    assert result.exit_code == 1  # labels renamed: a change, if not of behaviour
    assert "only labels renamed" in result.output
    result = runner.invoke(main, ["diff", str(old), str(old), "--equivalent", "--timeout", "300s"])
    assert result.exit_code == 0, result.output
    assert "equivalent: the same outputs" in result.output


def test_an_image_with_its_source_compares_with_the_source(tmp_path: Path, runner):
    old = _write(tmp_path, "old.asi", OLD)
    image = tmp_path / "old.hex"
    assert runner.invoke(main, ["compile", str(old), "-o", str(image)]).exit_code == 0
    result = runner.invoke(main, ["diff", str(image), str(old), "--equivalent",
                                  "--timeout", "300s"])
    assert result.exit_code == 0, result.output
    assert "3 networks the same, 0 changed" in result.output


def test_renamed_flags_and_timers_are_still_equivalent(tmp_path: Path):
    """Equal bits under other names: the invariant pairs a bit of one program with a bit
    of the other (here the demo timer.asi with F 0.0 -> F 7.1 and T 6 -> T 9)."""
    demo = (Path(__file__).resolve().parents[2] / "demos" / "timer.asi").read_text()
    old = _program(_write(tmp_path, "old.asi", demo))
    new = _program(_write(tmp_path, "new.asi",
                          demo.replace("F 0.0", "F 7.1").replace("T 6", "T 9")))
    result = equivalent(old, new, timeout_s=300, cycle_ms=100)
    assert result.verdict == "equivalent"
    changed = _program(_write(tmp_path, "changed.asi", demo.replace("KT 5000", "KT 4000")))
    assert equivalent(old, changed, timeout_s=300, cycle_ms=500).verdict == "different"


def test_images_without_source_compare_by_their_code(tmp_path: Path, runner):
    old = _write(tmp_path, "old.asi", OLD)
    changed = _write(tmp_path, "changed.asi", CHANGED)
    images = {}
    for path in (old, changed):
        images[path.stem] = tmp_path / f"{path.stem}.hex"
        result = runner.invoke(main, ["compile", str(path), "--no-source", "-o",
                                      str(images[path.stem])])
        assert result.exit_code == 0, result.output
    result = runner.invoke(main, ["diff", str(images["old"]), str(images["old"])])
    assert result.exit_code == 0 and "identical code" in result.output
    result = runner.invoke(main, ["diff", str(images["old"]), str(images["changed"]),
                                  "--equivalent"])
    assert result.exit_code == 1 and "the images differ in code" in result.output


def test_the_api_takes_builds_as_mutation_testing_passes_them(tmp_path: Path):
    old = build_file(_write(tmp_path, "old.asi", OLD))
    new = build_file(_write(tmp_path, "new.asi", REFACTORED))
    assert equivalent(old, new, timeout_s=300).verdict == "equivalent"
    asm = build_file(_write(tmp_path, "asm.asi", OLD.replace("***\n", "    ASM nop\n***\n", 1)))
    result = equivalent(old, asm, timeout_s=300)
    assert result.verdict == "unknown" and result.refused is not None
    assert "nop" in result.note


def test_a_difference_is_told_bit_by_bit_with_the_symbols_beside_new(tmp_path: Path, runner):
    setup = "[SETUP]\n1: iiii, 0\n3: oooo, 0\n[PROGRAM]\n"
    (tmp_path / "old.asi").write_text(setup + "    A I 1.0\n    = Q 3.1\n")
    (tmp_path / "new.asi").write_text(setup + "    AN I 1.0\n    = Q 3.1\n")
    (tmp_path / "new.symbols.toml").write_text('PumpB = "Q 3.1"\n')
    result = runner.invoke(main, ["diff", str(tmp_path / "old.asi"), str(tmp_path / "new.asi"),
                                  "--equivalent", "--cycle-ms", "10"])
    assert result.exit_code == 1, result.output
    # the quietest input sequence tells them apart: nothing set, I 1.0 stays 0
    assert "different after cycle 1: Q 3.1 (PumpB) is 0 in old.asi, 1 in new.asi" \
        in result.output


def test_symbols_names_the_table_that_names_the_difference(tmp_path: Path, runner):
    setup = "[SETUP]\n1: iiii, 0\n3: oooo, 0\n[PROGRAM]\n"
    (tmp_path / "old.asi").write_text(setup + "    A I 1.0\n    = Q 3.1\n")
    (tmp_path / "new.asi").write_text(setup + "    AN I 1.0\n    = Q 3.1\n")
    (tmp_path / "new.symbols.toml").write_text('PumpB = "Q 3.1"\n')
    (tmp_path / "plant.toml").write_text('Drain = "Q 3.1"\n')
    args = ["diff", str(tmp_path / "old.asi"), str(tmp_path / "new.asi"), "--equivalent",
            "--cycle-ms", "10", "--force"]
    result = runner.invoke(main, [*args, "--symbols", str(tmp_path / "plant.toml")])
    assert result.exit_code == 1, result.output
    assert "Q 3.1 (Drain) is 0 in old.asi, 1 in new.asi" in result.output
    assert "PumpB" not in result.output
    assert "(Drain)" in (tmp_path / "new.differs.scenario.toml").read_text()
    missing = runner.invoke(main, [*args, "--symbols", str(tmp_path / "none.toml")])
    assert missing.exit_code == 2 and "none.toml" in missing.output
