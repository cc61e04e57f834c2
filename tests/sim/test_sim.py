"""``asictl sim`` and ``asictl test`` end to end: the manual's examples as scenarios,
failure reports, program stops, determinism, JUnit output, bad input."""

from __future__ import annotations

import importlib.util
import json
import os
import pty
import re
import subprocess
import sys
from pathlib import Path
from xml.etree import ElementTree

import pytest
from click.testing import CliRunner

from asictl.build import build_file
from asictl.cli import main
from asictl.platform import pc2 as d
from asictl.sim.engine import Simulation, variables_of
from asictl.sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"


def run(*args: str):
    return CliRunner().invoke(main, list(args))


@pytest.mark.parametrize("name", sorted(p.name for p in SCENARIOS.glob("*.scenario.toml")))
def test_manual_example_scenarios_pass(name: str):
    result = run("sim", "--scenario", str(SCENARIOS / name))
    assert result.exit_code == 0, result.output
    assert ", 0 failed" in result.output


def test_set_pp_example_changes_the_masters_permanent_parameter():
    built = build_file(SCENARIOS / "set_pp.asi")
    assert built.image is not None
    scenario = load_scenario(SCENARIOS / "set_pp.scenario.toml", variables_of(built.image.pmap))
    sim = Simulation(built, scenario)
    sim.run()
    assert sim.board.dpram[d.PP + 8] >> 4 == 0x0A  # slave 17: high nibble of byte 8


def write(tmp_path: Path, name: str, text: str) -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize(("cycle_ms", "at", "expected", "said"), [
    (5, "at_ms = 250", 0, "at 250 ms: Q 31.0 expected 0, got 1"),
    # late times read as a person reads them, and exactly (not 'at 7.2e+06 ms')
    (50, 'at = "2h"', 1, "at 2 h 0 min (7200000 ms): Q 31.0 expected 1, got 0"),
])
def test_a_failed_expectation_is_reported_with_line_and_exit_1(
    tmp_path: Path, cycle_ms: int, at: str, expected: int, said: str,
):
    program = str(SCENARIOS / "blink.asi")
    scenario = write(tmp_path, "s.toml", (
        f'program = "{program}"\n[master]\ncycle_ms = {cycle_ms}\n'
        f'[[step]]\n{at}\nexpect = {{ "Q 31.0" = {expected} }}\n'
    ))
    result = run("sim", "--scenario", scenario)
    assert result.exit_code == 1, result.output
    assert f"{scenario}:6: {said}" in result.output
    assert "1 expectation, 1 failed" in result.output


def test_a_scenario_without_steps_says_so(tmp_path: Path):
    empty = write(tmp_path, "empty.toml", "")
    result = run("sim", str(SCENARIOS / "blink.asi"), "--scenario", empty)
    assert result.exit_code == 0, result.output
    assert f"{empty}: note: no steps: nothing is set or expected at a time" in result.stderr
    stepped = write(tmp_path, "s.toml", '[[step]]\nat_ms = 0\nset = { "I 1.0" = 1 }\n')
    assert "no steps" not in run("sim", str(SCENARIOS / "blink.asi"), "--scenario",
                                 stepped).stderr


def test_program_stops_are_reported_with_their_time(tmp_path: Path):
    program = write(tmp_path, "loop.asi", (
        "[SETUP]\n1: iiii, 0\n[PROGRAM]\n    A I 1.0\n    JC = stuck\n    BE\n"
        "stuck: JU = stuck\n"
    ))
    scenario = write(tmp_path, "s.toml", (
        '[master]\ncycle_ms = 5\n[[step]]\nat_ms = 50\nset = { "I 1.0" = 1 }\n'
        '[[step]]\nat_ms = 100\nexpect = { "QB 0" = 0 }\n'
    ))
    result = run("sim", program, "--scenario", scenario, "--json")
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)  # (stderr: the W208 of the loop)
    [stop] = report["stops"]
    assert 50 <= stop["at_ms"] <= 60 and "cycle" in stop["reason"]


def test_same_scenario_twice_gives_identical_vcd_and_csv(tmp_path: Path):
    outputs = []
    for i in range(2):
        vcd, csv = tmp_path / f"{i}.vcd", tmp_path / f"{i}.csv"
        result = run("sim", "--scenario", str(SCENARIOS / "or_and_not.scenario.toml"),
                     "--vcd", str(vcd), "--csv", str(csv))
        assert result.exit_code == 0, result.output
        outputs.append((vcd.read_bytes(), csv.read_bytes()))
    assert outputs[0] == outputs[1]
    assert b"Q_17_3" in outputs[0][0] and b"I 4.0" in outputs[0][1]


def test_setting_a_slave_that_is_not_on_the_bus_is_bad_input(tmp_path: Path):
    scenario = write(tmp_path, "s.toml", (
        f'program = "{SCENARIOS / "blink.asi"}"\n[[step]]\nat_ms = 5\nset = {{ "I 9.0" = 1 }}\n'
    ))
    result = run("sim", "--scenario", scenario)
    assert result.exit_code == 2
    assert f"{scenario}:4:1: error: at 5 ms: 'I 9.0' sets slave 9, which is not on the bus" \
        in result.stderr


def test_expecting_an_output_of_a_slave_not_on_the_bus_is_bad_input(tmp_path: Path):
    """An absent slave's outputs read 0: a typo in its address would pass quietly."""
    for operand in ("Q 9.0", "QB 8", "Q 9"):
        scenario = write(tmp_path, "s.toml", (
            f'program = "{SCENARIOS / "blink.asi"}"\n[[step]]\nat_ms = 5\n'
            f'expect = {{ "{operand}" = 0 }}\n'
        ))
        result = run("sim", "--scenario", scenario)
        assert result.exit_code == 2, (operand, result.output)
        assert (f"{scenario}:4:1: error: at 5 ms: '{operand}' expects slave "
                f"{operand.split()[1].split('.')[0]}, which is not on the bus") in result.stderr


def test_unknown_operand_is_bad_input_with_its_line(tmp_path: Path):
    scenario = write(tmp_path, "s.toml", (
        f'program = "{SCENARIOS / "blink.asi"}"\n[[step]]\nat_ms = 5\nexpect = {{ "Z 1.0" = 1 }}\n'
    ))
    result = run("sim", "--scenario", scenario)
    assert result.exit_code == 2
    assert f"{scenario}:4:12: error:" in result.stderr


def test_test_command_summary_and_junit(tmp_path: Path):
    (tmp_path / "blink.asi").write_text((SCENARIOS / "blink.asi").read_text())
    (tmp_path / "blink.scenario.toml").write_text(
        '[master]\ncycle_ms = 5\n[[step]]\nat_ms = 250\nexpect = { "Q 31.0" = 1 }\n'
    )
    (tmp_path / "bad.scenario.toml").write_text(
        f'program = "{tmp_path / "blink.asi"}"\n[master]\ncycle_ms = 5\n'
        '[[step]]\nat_ms = 750\nexpect = { "Q 31.0" = 1 }\n'
    )
    junit = tmp_path / "out.xml"
    result = run("test", str(tmp_path), "--junit", str(junit))
    assert result.exit_code == 1
    assert result.output.splitlines()[-1] == "1 passed, 1 failed"
    assert "FAIL " in result.output and "PASS " in result.output
    suite = ElementTree.parse(junit).getroot()
    assert (suite.get("tests"), suite.get("failures")) == ("2", "1")


def test_plot(tmp_path: Path):
    png = tmp_path / "b.png"
    result = run("sim", "--scenario", str(SCENARIOS / "blink.scenario.toml"), "--plot", str(png))
    if importlib.util.find_spec("matplotlib") is None:
        assert result.exit_code == 2
        assert "pip install '.[plot]'" in result.stderr
    else:
        assert result.exit_code == 0, result.output
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _normal(text: str) -> str:
    """Output without wall-clock times (they differ from run to run)."""
    text = re.sub(r"in [\d.]+ (µs|ms|s)\b", "in T", text)
    return re.sub(r'time="\d+\.\d+"', 'time="T"', text)


def test_parallel_test_runs_give_the_same_output_and_junit(tmp_path: Path):
    for scenario in SCENARIOS.glob("*"):
        (tmp_path / scenario.name).write_bytes(scenario.read_bytes())
    (tmp_path / "blink_fails.scenario.toml").write_text(
        f'program = "{tmp_path / "blink.asi"}"\n[master]\ncycle_ms = 5\n'
        '[[step]]\nat_ms = 750\nexpect = { "Q 31.0" = 1 }\n')
    (tmp_path / "broken.scenario.toml").write_text(
        f'program = "{tmp_path / "blink.asi"}"\n[[step]]\nat_ms = nan\n')
    outputs = []
    for jobs in ("1", "2", "3"):
        junit = tmp_path / f"junit{jobs}.xml"
        result = run("test", str(tmp_path), "-j", jobs, "--junit", str(junit))
        assert result.exit_code == 2
        outputs.append((_normal(result.stdout), result.stderr, _normal(junit.read_text())))
    assert outputs[0] == outputs[1] == outputs[2]
    lines = outputs[0][0].splitlines()
    passing = len(list(SCENARIOS.glob("*.scenario.toml")))
    assert lines[-1] == f"{passing} passed, 2 failed"
    assert [line.split()[0] for line in lines if not line.startswith(" ")][:-1] == [
        "PASS", "FAIL", "ERROR", *["PASS"] * (passing - 1)]


def test_test_shows_its_progress_on_a_terminal_and_not_in_a_pipe(tmp_path: Path):
    """On a terminal, standard error carries one line rewritten per scenario (done of
    all, failures so far), cleared at the end; in a pipe nothing of it."""
    for scenario in SCENARIOS.glob("*"):
        (tmp_path / scenario.name).write_bytes(scenario.read_bytes())
    (tmp_path / "blink_fails.scenario.toml").write_text(
        f'program = "{tmp_path / "blink.asi"}"\n[master]\ncycle_ms = 5\n'
        '[[step]]\nat_ms = 750\nexpect = { "Q 31.0" = 1 }\n')
    total = len(list(tmp_path.glob("*.scenario.toml")))
    command = [sys.executable, "-m", "asictl", "test", str(tmp_path), "-j", "2"]
    leader, follower = pty.openpty()
    try:
        done = subprocess.run(command, stdout=subprocess.PIPE, stderr=follower, timeout=120)
        os.close(follower)
        seen = b""
        while True:
            try:
                chunk = os.read(leader, 4096)
            except OSError:  # the terminal's other end is closed: all read
                break
            if not chunk:
                break
            seen += chunk
    finally:
        os.close(leader)
    assert done.returncode == 1
    shown = seen.decode()
    assert f"[{total}/{total}] 1 failed" in shown
    assert shown.endswith("\r\x1b[K")  # the line is gone when the summary prints
    piped = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert "failed\r" not in piped.stderr and "\x1b[K" not in piped.stderr
    assert piped.stdout.splitlines()[-1] == done.stdout.decode().splitlines()[-1]


FINAL = """[SETUP]
1: iiii, 0
2: oooo, 0
[PROGRAM]
    A I 1.0
    = Q 2.1
    CU C 3
    ***
    AN I 1.0
    L KT 500
    S T 4
"""


def test_sim_without_expectations_shows_what_the_program_left(tmp_path: Path):
    """Without a scenario's expectations, the outputs, counters and timers at the end."""
    program = tmp_path / "p.asi"
    program.write_text(FINAL)
    result = run("sim", str(program), "--set", "I 1.0=1", "--duration", "100ms")
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[0] == "at 100 ms:"
    assert "  outputs   Q 2 = 0010" in lines
    counted = next(line for line in lines if line.startswith("  counters"))
    assert int(counted.split("C 3 = ")[1]) >= 5  # once per cycle while I 1.0 is 1
    assert "  timers    T 4 = 0 ms" in lines  # AN I 1.0 is 0: never started
    data = json.loads(run("sim", str(program), "--duration", "100ms", "--json").stdout)
    assert data["final"]["outputs"] == {"2": 0}
    assert data["final"]["counters"] == {"3": 0}
    assert 400 <= data["final"]["timers_ms"]["4"] <= 500  # started: I 1.0 stays 0


def test_sim_with_expectations_shows_no_final_state():
    result = run("sim", "--scenario", str(SCENARIOS / "blink.scenario.toml"))
    assert "outputs " not in result.stdout and "expectations" in result.stdout
