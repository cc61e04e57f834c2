"""Bad numbers and hostile scenario files: always an error at the scenario's line (exit 2),
never an internal error; one bad scenario is one ERROR row of ``asictl test``."""

from __future__ import annotations

import json
from pathlib import Path
from xml.etree import ElementTree

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from asictl.cli import main
from asictl.sim.scenario import read_scenario
from asictl.source import from_string

BLINK = Path(__file__).resolve().parents[1] / "scenarios" / "blink.asi"


def sim(tmp_path: Path, scenario: str, *args: str):
    path = tmp_path / "s.toml"
    path.write_text(f'program = "{BLINK}"\n' + scenario)
    return CliRunner().invoke(main, ["sim", "--scenario", str(path), *args]), str(path)


@pytest.mark.parametrize(("text", "line", "message"), [
    ("[[step]]\nat_ms = inf\n", 3, "at_ms is a time in milliseconds from 0 to 86400000"),
    ("[[step]]\nat_ms = nan\n", 3, "not nan"),
    ("[[step]]\nat_ms = -1\n", 3, "at_ms is a time"),
    ("[[step]]\nat_ms = 1e12\n", 3, "(24 h)"),
    ("[[step]]\nat_ms = " + "9" * 400 + "\n", 3, "not 999999"),
    ('[[step]]\nat = "' + "9" * 400 + 's"\n', 3, "is not a duration"),
    ('[[step]]\nat = "25h"\n', 3, "longer than the longest allowed, 24 h"),
    ("[master]\ncycle_ms = 0.0001\n", 3, "cycle_ms is a time in milliseconds from 0.1 to 10000"),
    ("[master]\ncycle_ms = inf\n", 3, "not inf"),
    ("[master]\ncycle_ms = nan\n", 3, "not nan"),
    ("[master]\ncycle_ms = 1e12\n", 3, "not 1000000000000.0"),
    ("[master]\nfirst_tick_ms = 0\n", 3, "first_tick_ms is a time in milliseconds from "
     "0.001 to 10, not 0"),
    ("[master]\nfirst_tick_ms = 10.5\n", 3, "not 10.5"),
    ("[master]\nfirst_tick_ms = nan\n", 3, "not nan"),
    ("[master]\nfirst_tick_ms = true\n", 3, "first_tick_ms is a time"),
    ("x = " + "[" * 500 + "]" * 500 + "\n", 2, "nested more than 32 deep"),
    ("[[step]]\nat_ms = 0\nset = { \"I 31.0\" = " + "9" * 5000 + " }\n", 1, "not valid TOML"),
])
def test_bad_numbers_are_scenario_errors_at_their_line(tmp_path, text, line, message):
    result, path = sim(tmp_path, text)
    assert result.exit_code == 2, result.output
    assert f"{path}:{line}:" in result.stderr and message in result.stderr, result.stderr
    assert "internal error" not in result.stderr


@pytest.mark.parametrize("duration", ["9" * 400, "inf", "nan", "25h", "1e3"])
def test_bad_durations_are_usage_errors(tmp_path, duration):
    result, _ = sim(tmp_path, "[[step]]\nat_ms = 5\n", "--duration", duration)
    assert result.exit_code == 2 and "--duration" in result.stderr, result.output
    assert "internal error" not in result.stderr


def test_a_long_cycle_time_is_simulated(tmp_path):
    result, _ = sim(tmp_path, "[master]\ncycle_ms = 10000\n[[step]]\nat_ms = 25000\n", "--json")
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert (report["end_ms"], report["stops"]) == (25000, [])


def test_json_never_carries_nan(tmp_path):
    result, _ = sim(tmp_path, "[[step]]\nat_ms = 5\n", "--json")
    json.loads(result.output, parse_constant=lambda name: pytest.fail(f"{name} in JSON"))


def test_a_bad_scenario_is_one_error_row_and_the_others_still_run(tmp_path: Path):
    (tmp_path / "blink.asi").write_text(BLINK.read_text())
    (tmp_path / "blink.scenario.toml").write_text(
        '[master]\ncycle_ms = 5\n[[step]]\nat_ms = 250\nexpect = { "Q 31.0" = 1 }\n')
    (tmp_path / "a.scenario.toml").write_text(
        f'program = "{tmp_path / "blink.asi"}"\n[[step]]\nat_ms = nan\n')
    (tmp_path / "z.scenario.toml").write_text(
        f'program = "{tmp_path / "blink.asi"}"\n' + "x = " + "[" * 600 + "]" * 600 + "\n")
    junit = tmp_path / "out.xml"
    result = CliRunner().invoke(main, ["test", "-j", "1", str(tmp_path), "--junit", str(junit)])
    assert result.exit_code == 2, result.output
    rows = result.stdout.splitlines()
    assert rows[0].startswith("ERROR ") and "a.scenario.toml" in rows[0]
    assert rows[1].startswith("PASS ") and "blink.scenario.toml" in rows[1]
    assert rows[2].startswith("ERROR ") and "z.scenario.toml" in rows[2]
    assert rows[-1] == "1 passed, 2 failed"
    assert "a.scenario.toml:3:" in result.stderr and "z.scenario.toml:2:" in result.stderr
    suite = ElementTree.parse(junit).getroot()
    assert (suite.get("tests"), suite.get("errors")) == ("3", "2")


def test_inline_step_arrays_give_each_step_its_own_line():
    """(benchmarks/bench_scenario.py shows the reading time grows linearly with the steps)"""
    n = 300
    text = "step = [\n" + "".join(
        f'  {{ at_ms = {i}, set = {{ "I 1.0" = {i % 2} }} }},\n' for i in range(n)) + "]\n"
    scenario = read_scenario(from_string("s.toml", text))
    assert [s.line for s in scenario.steps] == list(range(2, n + 2))
    assert [s.set[0][2] for s in scenario.steps] == list(range(2, n + 2))


# ------------------------------------------------------------------------ generated files

KEYS = ["at_ms", "at", "set", "expect", "cycle_ms", "slaves", "program", "step", "master",
        "remove_slaves", "add_slaves", "power_fail", "press_set_button", "markers"]
VALUES = ["0", "1", "-1", "5.5", "inf", "nan", "-inf", "1e12", "1e400", "9" * 50, "true",
          '"250ms"', '"1h"', '"x"', '"I 1.0"', "[]", "[1, 2]", "{}", '{ "I 31.0" = 1 }',
          '{ "Q 31.0" = 1 }', '{ "CV 0" = 4095 }', '{ "TV 1" = 99999 }', '{ 31 = "iiii,0" }',
          '{ 40 = "zz" }', "0x21", '"blink.asi"', "[[[[[[1]]]]]]", '"' + "9" * 300 + 'ms"']


@st.composite
def scenario_texts(draw: st.DrawFn) -> str:
    lines = []
    for _ in range(draw(st.integers(0, 12))):
        kind = draw(st.integers(0, 3))
        if kind == 0:
            lines.append(draw(st.sampled_from(["[[step]]", "[master]", "[step]", "[[master]]"])))
        elif kind == 3:
            lines.append(draw(st.text(max_size=20)))
        else:
            lines.append(f"{draw(st.sampled_from(KEYS))} = {draw(st.sampled_from(VALUES))}")
    return "\n".join(lines) + "\n"


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenario_texts())
def test_random_scenarios_never_exit_3(tmp_path_factory, text: str):
    path = tmp_path_factory.mktemp("s") / "s.toml"
    path.write_text(f'program = "{BLINK}"\n' + text, encoding="utf-8")
    result = CliRunner().invoke(main, ["sim", "--scenario", str(path), "--duration", "50ms",
                                       "--allow-partial", "--json"])
    assert result.exit_code in (0, 1, 2), result.output
    assert "internal error" not in result.output and "Traceback" not in result.output
    if result.exit_code in (0, 1):
        json.loads(result.stdout)


@pytest.mark.parametrize("option", ["--duration", "--from", "--to"])
def test_a_bare_number_on_the_command_line_shows_both_readings(tmp_path, option):
    result, _ = sim(tmp_path, "[[step]]\nat_ms = 5\n", option, "16")
    assert result.exit_code == 2, result.output
    assert "'16' has no unit: give a unit: 16ms or 16s" in result.stderr
    result, _ = sim(tmp_path, "[[step]]\nat_ms = 5\n", option, "16ms")
    assert result.exit_code == 0, result.output
