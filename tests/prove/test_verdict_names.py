"""Every verdict line and note names operands by the program's symbol table, the one
beside the program or the one given with --symbols: ``Q 3.1 (PumpB)``; and mutation
testing's notes name the bits of an output byte the same way."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from test_counterexample_bits import PROGRAM as LATCH

from asictl.cli import main
from asictl.il.ast import key
from asictl.observe.names import named, named_bits
from asictl.observe.symbols import SymbolTable
from asictl.quality.refute import Difference

pytest.importorskip("z3")

PROGRAM = LATCH + """        L   KT 5000
        A   I 1.3
        S   T 1
        A   T 1
        =   Q 3.2
***
"""

PROPS = """[master]
cycle_ms = 10
[[property]]
name = "latch never with I 1.3"
never = "Q 3.1 and I 1.3"
[[property]]
name = "the timer output can come on"
reachable = "Q 3.2"
"""

SYMBOLS = 'Start = "I 1.0"\nPumpB = "Q 3.1"\nRunning = "Q 3.2"\nDelay = "T 1"\n'


def _table(text: str) -> SymbolTable:
    names = dict(line.replace('"', "").split(" = ") for line in text.splitlines())
    return SymbolTable("t.symbols.toml", {key(n): (n, o) for n, o in names.items()})


def test_named_shows_the_symbol_beside_the_operand():
    table = _table('PumpB = "Q 3.1"\nParts = "C 0"\n')
    assert named("Q 3.1", table) == "Q 3.1 (PumpB)"
    assert named("CV 0", table) == "CV 0 (Parts)"
    assert named("Q 3.0", table) == "Q 3.0"
    assert named_bits("QB 2", 16, 48, table) == [("Q 3.1 (PumpB)", 0, 1)]


def test_a_mutants_difference_names_the_bits_of_its_output_byte():
    table = _table('PumpB = "Q 3.1"\n')
    assert Difference("QB 2", 0x20, 0x00, 4986).describe(table) == (
        "not equivalent: Q 3.1 (PumpB) differs from the original's after 4986 ms of "
        "random inputs")
    assert Difference("QB 2", 0x21, 0x00, 7).describe(SymbolTable()).startswith(
        "not equivalent: Q 2.0, Q 3.1 differ from")
    timer = _table('Delay = "T 7"\n')
    assert Difference("T 7", 120, 121, 0, (1, 2)).describe(timer) == (
        "not equivalent: T 7 (Delay) differs from the original's after 0 ms of I 1.2 "
        "toggling every cycle")


def _run(runner, tmp_path: Path, *extra: str) -> tuple[int, str]:
    result = runner.invoke(main, ["prove", str(tmp_path / "p.props.toml"), "--depth", "8",
                                  "--counterexamples", str(tmp_path / "cex"), *extra])
    return result.exit_code, result.output


def test_verdict_lines_and_notes_name_operands_beside_the_program(tmp_path: Path, runner):
    (tmp_path / "p.asi").write_text(PROGRAM)
    (tmp_path / "p.props.toml").write_text(PROPS)
    (tmp_path / "p.symbols.toml").write_text(SYMBOLS)
    code, output = _run(runner, tmp_path)
    assert code == 1, output
    lines = output.splitlines()
    refuted = next(line for line in lines if "latch never" in line)
    assert refuted.lstrip().startswith("refuted")
    assert "with Q 3.1 (PumpB) = 1, I 1.3 = 1:" in refuted
    reached = next(line for line in lines if "can come on" in line)
    assert "with Q 3.2 (Running) = 1" in reached


def test_symbols_given_on_the_command_line(tmp_path: Path, runner):
    (tmp_path / "p.asi").write_text(PROGRAM)
    (tmp_path / "p.props.toml").write_text(PROPS.replace("Q 3.1 and", "Pump and"))
    (tmp_path / "other.toml").write_text('Pump = "Q 3.1"\n')
    code, output = _run(runner, tmp_path, "--symbols", str(tmp_path / "other.toml"))
    assert code == 1, output
    assert "with Q 3.1 (Pump) = 1, I 1.3 = 1:" in output
    # a table that is not there is bad input
    code, output = _run(runner, tmp_path, "--symbols", str(tmp_path / "none.toml"))
    assert code == 2 and "none.toml" in output


def test_json_gives_the_operands_named_and_the_phase(tmp_path: Path, runner):
    (tmp_path / "p.asi").write_text(PROGRAM)
    (tmp_path / "p.props.toml").write_text(PROPS)
    (tmp_path / "p.symbols.toml").write_text(SYMBOLS)
    code, output = _run(runner, tmp_path, "--format", "json")
    assert code == 1, output
    results = {r["name"]: r for r in json.loads(output)["files"][0]["results"]}
    latch = results["latch never with I 1.3"]
    assert latch["operands"] == [
        {"operand": "Q 3.1", "named": "Q 3.1 (PumpB)", "value": 1},
        {"operand": "I 1.3", "named": "I 1.3", "value": 1}]
    timer = results["the timer output can come on"]
    assert timer["operands"][0]["named"] == "Q 3.2 (Running)"
    assert 0 < timer["first_tick_ms"] <= 10
