"""What ``asictl sim`` shows of a program: counter and timer values (``CV n``, ``TV n``),
symbols, the IL line of a stop, firmware refusals, events in time order, the scenario
beside the program, ``--set``, ``--duration`` against the scenario, lane selection."""

from __future__ import annotations

import csv
import importlib.util
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.cli import main

COUNTER = """\
[SETUP]
1: iiii, 0
2: oooo, 0
[PROGRAM]
    A   I 1.0
    L   KC 4095
    S   C 0
***
    A   I 1.1
    CD  C 0
***
    A   I 1.2
    L   KT 500
    S   T 1
***
    A   C 0
    =   Q 2.0
"""

SCENARIO = """\
[master]
cycle_ms = 5
[[step]]
at_ms = 0
set = { "I 1.0" = 1, "I 1.2" = 1 }
[[step]]
at_ms = 10
set = { "I 1.0" = 0, "I 1.1" = 1 }
[[step]]
at_ms = 15
set = { "I 1.1" = 0, "I 1.2" = 0 }
[[step]]
at_ms = 20
expect = { "CV 0" = 4094, "C 0" = 1, "Q 2.0" = 1, "T 1" = 1 }
"""


def run(*args: str):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture
def counter(tmp_path: Path) -> Path:
    program = tmp_path / "count.asi"
    program.write_text(COUNTER)
    (tmp_path / "count.scenario.toml").write_text(SCENARIO)
    return program


def rows(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(path.read_text().splitlines()))


def test_the_scenario_beside_the_program_is_checked_with_counter_values(counter: Path):
    result = run("sim", counter, "--json")
    assert result.exit_code == 0, result.output
    assert f"checking {counter.with_name('count.scenario.toml')}" in result.stderr
    report = json.loads(result.stdout)
    assert (report["checked"], report["failures"]) == (4, [])


def test_a_wrong_counter_value_fails(counter: Path):
    counter.with_name("count.scenario.toml").write_text(
        SCENARIO.replace('"CV 0" = 4094', '"CV 0" = 4093'))
    result = run("sim", counter)
    assert result.exit_code == 1
    assert "count.scenario.toml:14: at 20 ms: CV 0 expected 4093, got 4094" in result.stdout


def test_csv_has_counter_and_timer_columns(counter: Path, tmp_path: Path):
    out = tmp_path / "t.csv"
    assert run("sim", counter, "--csv", out).exit_code == 0
    table = rows(out)
    for column in ("C 0", "CV 0", "T 1", "TV 1", "program running", "I 1.0", "Q 2.0"):
        assert column in table[0], column
    assert table[0]["CV 0"] == "4095" and table[-1]["CV 0"] == "4094"
    remaining = [int(r["TV 1"]) for r in table]
    assert remaining[0] == 500 and remaining[-1] == 490  # loaded every cycle until 15 ms
    assert all(int(r["program running"]) == 1 for r in table)


def test_signals_choose_lanes_in_their_order(counter: Path, tmp_path: Path):
    out = tmp_path / "t.csv"
    assert run("sim", counter, "--csv", out, "--signals", "Q 2.*, CV*,I 1.1").exit_code == 0
    assert out.read_text().splitlines()[0] == "time_ms,Q 2.0,CV 0,I 1.1"


def test_symbols_name_operands_in_scenarios_traces_and_reports(counter: Path, tmp_path: Path):
    (tmp_path / "count.symbols.toml").write_text(
        'Load = "I 1.0"\nCountDown = "I 1.1"\nParts = "C 0"\nLamp = "Q 2.0"\n')
    counter.with_name("count.scenario.toml").write_text(
        SCENARIO.replace('"I 1.0" = 1', "Load = 1").replace('"I 1.0" = 0', "Load = 0")
        .replace('"CV 0" = 4094', '"CV Parts" = 4000').replace('"Q 2.0" = 1', "Lamp = 1"))
    out = tmp_path / "t.csv"
    result = run("sim", counter, "--csv", out)
    assert result.exit_code == 1
    assert "at 20 ms: CV Parts expected 4000, got 4094" in result.stdout
    header = out.read_text().splitlines()[0].split(",")
    assert {"Load", "CountDown", "Lamp", "Parts", "CV Parts"} <= set(header)
    assert "I 1.0" not in header


def test_a_bad_symbol_table_is_an_error_at_its_line(counter: Path, tmp_path: Path):
    table = tmp_path / "count.symbols.toml"
    table.write_text('Start = "I 1.0"\nMotor = "Q 99.0"\nT1 = "Q 2.0"\n')
    result = run("sim", counter)
    assert result.exit_code == 2
    assert f"{table}:2:1: error: symbol 'Motor': 'Q 99.0': slave 0..31" in result.stderr
    assert f"{table}:3:1: error: symbol 'T1' reads as an operand itself" in result.stderr


def test_set_runs_without_a_scenario(counter: Path, tmp_path: Path):
    out = tmp_path / "t.csv"
    result = run("sim", counter, "--no-scenario", "--set", "I 1.0=1", "--set", "I 1.1=1",
                 "--duration", "50ms", "--csv", out)
    assert result.exit_code == 0, result.output
    assert rows(out)[-1]["CV 0"] == "4094"  # loaded, then counted down, every cycle
    bad = run("sim", counter, "--no-scenario", "--set", "Q 2.0=1")
    assert bad.exit_code == 2 and "cannot be set" in bad.stderr


def test_a_slaves_four_data_bits_and_every_value_form(counter: Path, tmp_path: Path):
    """Scenarios and --set read operands and values as ``asictl write`` does: ``I 1`` is
    slave 1's four inputs, ``Q 2`` slave 2's four outputs; TOML's and IL's number forms."""
    scenario = tmp_path / "nibble.scenario.toml"
    scenario.write_text(
        '[master]\ncycle_ms = 5\n[[step]]\nat_ms = 0\nset = { "I 1" = 0b0001 }\n'
        '[[step]]\nat_ms = 10\nexpect = { "Q 2" = 0b0001, "I 1" = 1, "CV 0" = 4095 }\n')
    result = run("sim", counter, "--scenario", scenario)
    assert result.exit_code == 0, result.output
    out = tmp_path / "t.csv"
    result = run("sim", counter, "--no-scenario", "--set", "I 1=0b0011", "--set", "FY 10=0Ah",
                 "--duration", "50ms", "--csv", out, "--signals", "CV 0")
    assert result.exit_code == 0, result.output
    assert rows(out)[-1]["CV 0"] == "4094"
    bad = run("sim", counter, "--no-scenario", "--set", "I 1=16")
    assert bad.exit_code == 2
    assert "--set 'I 1=16': 'I 1': value 16 out of range 0..15 (four data bits)" in bad.stderr


def test_a_duration_shorter_than_the_scenario_is_an_error(counter: Path):
    result = run("sim", counter, "--duration", "15ms")
    assert result.exit_code == 2
    assert "ends before the scenario's last step at 20 ms" in result.stderr
    partial = run("sim", counter, "--duration", "15ms", "--allow-partial")
    assert partial.exit_code == 0, partial.output
    assert "(1 step after the end not run)" in partial.stdout


LOOP = """\
[SETUP]
1: iiii, 0
[PROGRAM]
    A   I 1.0
    JC  = stuck
    BE
stuck:
    A   I 1.1
    JU  = stuck
"""


def test_an_endless_loop_is_reported_at_its_jump_line(tmp_path: Path):
    program = tmp_path / "loop.asi"
    program.write_text(LOOP)
    result = run("sim", program, "--set", "I 1.0=1", "--duration", "20ms")
    assert result.exit_code == 0, result.output
    assert f"at 0 ms: program stopped: {program.name}:9: program cycle time-out" in result.stdout


def test_a_loop_in_a_block_names_the_block_line_and_its_caller(tmp_path: Path):
    (tmp_path / "spin.fb").write_text("[PROGRAM]\n    L KB 1\nagain:\n    JU = again\n")
    program = tmp_path / "main.asi"
    program.write_text("[SETUP]\n1: iiii, 0\n[DECL]\nSpin FB spin.fb\n[PROGRAM]\n"
                       "    A I 1.0\n    JC FB Spin\n")
    result = run("sim", program, "--set", "I 1.0=1", "--duration", "10ms", "--json")
    [stop] = json.loads(result.stdout)["stops"]
    assert stop["where"] == "spin.fb:4 (called from main.asi:7)"


def test_events_come_in_time_order_and_config_errors_name_the_slave(tmp_path: Path):
    program = tmp_path / "p.asi"
    program.write_text("[SETUP]\n1: iiii, 0\n2: oooo, 0\n[PROGRAM]\n    A I 1.0\n    = Q 2.0\n")
    (tmp_path / "p.scenario.toml").write_text(
        '[master]\ncycle_ms = 5\n'
        '[[step]]\nat_ms = 100\nexpect = { "Q 2.0" = 1 }\n'
        '[[step]]\nat_ms = 50\nremove_slaves = [2]\n'
        '[[step]]\nat_ms = 10\nexpect = { "Q 2.0" = 1 }\n'
    )
    result = run("sim", program)
    lines = result.stdout.splitlines()
    assert "at 10 ms: Q 2.0 expected 1" in lines[0]
    assert "program stopped: AS-i configuration error (slave 2 missing)" in lines[1]
    assert "at 100 ms: Q 2.0 expected 1" in lines[2]


def test_a_refused_firmware_block_is_noted_at_its_line(tmp_path: Path):
    program = tmp_path / "pp.asi"
    program.write_text("[SETUP]\n1: iiii, 0\n[PROGRAM]\n    L KB 40\n    T PSeg 0\n"
                       "    JU FB SetPP\n")
    result = run("sim", program, "--duration", "50ms")
    assert result.exit_code == 0, result.output
    assert "at 0 ms: note: pp.asi:6: firmware block SetPP refused (status 80h)" in result.stdout
    assert "more times until" in result.stdout


def test_plot_marks_failures_in_red(counter: Path, tmp_path: Path):
    counter.with_name("count.scenario.toml").write_text(
        SCENARIO.replace('"CV 0" = 4094', '"CV 0" = 1'))
    png = tmp_path / "t.png"
    result = run("sim", counter, "--plot", png, "--from", "5ms", "--to", "30ms")
    if importlib.util.find_spec("matplotlib") is None:
        assert result.exit_code == 2 and "pip install '.[plot]'" in result.stderr
        return
    assert result.exit_code == 1
    from matplotlib import image

    pixels = image.imread(png)
    red = (pixels[..., 0] > 0.9) & (pixels[..., 1] < 0.2) & (pixels[..., 2] < 0.2)
    assert red.sum() > 20


def test_long_times_read_as_people_read_them():
    """An hour of master time is ``1 h 0 min``, not ``3602.1 s`` or ``3.6021e+06 ms``;
    the exact milliseconds stand beside a moment."""
    timer = Path(__file__).resolve().parents[2] / "demos" / "1h_timer.asi"
    result = run("sim", str(timer))
    assert result.exit_code == 0, result.output
    assert "expectations, 0 failed; 1 h 0 min of master time in " in result.stdout
    short = run("sim", str(timer), "--duration", "2min")
    assert short.exit_code == 2
    assert ("--duration 2 min 0 s (120000 ms) ends before the scenario's last step at "
            "1 h 0 min (3602100 ms)") in short.stderr
