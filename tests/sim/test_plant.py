"""Plant models in scenarios (closed loop): each model's switching times against the
arithmetic of its table, a sequence program and its buggy twin, lanes in the traces,
determinism, and every kind of bad table as a located error."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.build import build_file
from asictl.cli import main
from asictl.sim.engine import SimResult, Simulation, variables_of
from asictl.sim.scenario import load_scenario, read_scenario
from asictl.source import from_string

#: Slave 3's inputs are what the scenario sets; the program copies them to slave 2's
#: outputs, which drive the models; the models drive slave 1's inputs.
FOLLOW = """[SETUP]
1: iiii, 0
2: oooo, 0
3: iiii, 0

[PROGRAM]
        A   I 3.0
        =   Q 2.0
***
        A   I 3.1
        =   Q 2.1
***
        A   I 3.2
        =   Q 2.2
***
        A   I 3.3
        =   Q 2.3
"""


def simulate(tmp_path: Path, scenario: str, program: str = FOLLOW) -> SimResult:
    (tmp_path / "p.asi").write_text(program)
    (tmp_path / "p.scenario.toml").write_text(scenario)
    built = build_file(tmp_path / "p.asi")
    assert built.image is not None, built.render()
    loaded = load_scenario(tmp_path / "p.scenario.toml", variables_of(built.image.pmap))
    return Simulation(built, loaded, trace=True).run()


def changes(result: SimResult, lane: str) -> list[tuple[float, int]]:
    assert result.trace is not None
    (signal,) = [s for s in result.trace.signals if s.name == lane]
    return signal.changes


def test_a_cylinder_closes_its_end_switches_a_stroke_after_it_is_driven(tmp_path: Path):
    result = simulate(tmp_path, """
[master]
cycle_ms = 5
[[plant]]
type = "cylinder"
extend = "Q 2.0"
extended = "I 1.0"
retracted = "I 1.1"
stroke_ms = 300
[[step]]
at_ms = 100
set = { "I 3.0" = 1 }
[[step]]
at_ms = 250
set = { "I 3.0" = 0 }
[[step]]
at_ms = 1000
""")
    # out from 100 ms: leaves the retracted switch at once; back at 250 after 150 ms out
    # (half the stroke), so in again 150 ms later: never at the end of the stroke
    assert changes(result, "I 1.1") == [(0, 1), (100.001, 0), (400, 1)]
    assert changes(result, "I 1.0") == [(0, 0)]
    assert changes(result, "cylinder1 position")[-1] == (400, 0)


def test_a_double_acting_cylinder_holds_its_position_between_its_outputs(tmp_path: Path):
    result = simulate(tmp_path, """
[master]
cycle_ms = 5
[[plant]]
name = "clamp"
type = "cylinder"
extend = "Q 2.0"
retract = "Q 2.1"
extended = "I 1.0"
stroke_ms = 200
[[step]]
at_ms = 0
set = { "I 3.0" = 1 }
[[step]]
at_ms = 100
set = { "I 3.0" = 0 }
[[step]]
at_ms = 500
set = { "I 3.0" = 1 }
[[step]]
at_ms = 700
expect = { "I 1.0" = 1 }
""")
    assert result.passed, result.failures
    assert changes(result, "I 1.0") == [(0, 0), (600, 1)]  # 100 ms, a pause, 100 ms
    assert (100, 50) in changes(result, "clamp position")


def test_a_conveyor_carries_parts_past_its_barrier_while_the_motor_runs(tmp_path: Path):
    result = simulate(tmp_path, """
[master]
cycle_ms = 5
[[plant]]
type = "conveyor"
motor = "Q 2.1"
length_mm = 1000
speed_mm_s = 500
parts_at_ms = [0, 2000]
barriers = [ { input = "I 1.3", at_mm = 800 }, { input = "I 1.2", at_mm = 0 } ]
[[step]]
at_ms = 100
set = { "I 3.1" = 1 }
[[step]]
at_ms = 600
set = { "I 3.1" = 0 }
[[step]]
at_ms = 1100
set = { "I 3.1" = 1 }
[[step]]
at_ms = 5000
""")
    # the first part: 500 ms of run, 500 ms standing, 1100 ms more to 800 mm at 2200 ms,
    # past 850 mm at 2300 ms, off the belt at 1000 mm (2500 ms); the second part put on at
    # 2000 ms reaches 800 mm 1600 ms later
    assert changes(result, "I 1.3") == [(0, 0), (2200, 1), (2300, 0), (3600, 1), (3700, 0)]
    # the barrier at 0 mm sees each part for its first 50 mm (100 ms of run)
    assert changes(result, "I 1.2") == [(0, 1), (200, 0), (2000, 1), (2100, 0)]
    assert changes(result, "conveyor1 parts")[-1] == (4000, 0)


def test_a_part_is_put_on_by_a_rising_edge_of_an_output(tmp_path: Path):
    result = simulate(tmp_path, """
[master]
cycle_ms = 5
[[plant]]
type = "conveyor"
motor = "Q 2.1"
part_on = "Q 2.2"
length_mm = 100
speed_mm_s = 1000
barriers = [ { input = "I 1.0", at_mm = 50 } ]
part_mm = 10
[[step]]
at_ms = 0
set = { "I 3.1" = 1 }
[[step]]
at_ms = 200
set = { "I 3.2" = 1 }
[[step]]
at_ms = 400
""")
    assert changes(result, "I 1.0") == [(0, 0), (250, 1), (260, 0)]


def test_a_tank_fills_to_its_level_switch(tmp_path: Path):
    program = """[SETUP]
1: iiii, 0
2: oooo, 0
3: iiii, 0

[PROGRAM]
        AN  I 1.0           ; fill while not full
        =   Q 2.0
***
        A   I 3.0           ; drain on request
        =   Q 2.1
"""
    result = simulate(tmp_path, """
[master]
cycle_ms = 5
[[plant]]
type = "tank"
fill = "Q 2.0"
fill_rate = 10
drain = "Q 2.1"
drain_rate = 20
level = 20
switches = [ { input = "I 1.0", at = 80 }, { input = "I 1.1", at = 10 } ]
[[step]]
at_ms = 10000
set = { "I 3.0" = 1 }
[[step]]
at_ms = 20000
""", program)
    # 20 -> 80 at 10 per second from time 0: full at 6 s; then draining at 20 per second
    # against the fill of 10 from 10 s on (the fill restarts at once below 80)
    full = changes(result, "I 1.0")
    assert full[:3] == [(0, 0), (6000, 1), (10000.001, 0)]
    # 20 per second for the cycle of 5 ms until the fill is on again (79.9), then 10 per
    # second down to 10 takes 6.99 s more
    assert changes(result, "I 1.1") == [(0, 1), (16995.001, 0)]
    assert changes(result, "tank1 level")[-1][1] == 0


def test_a_motor_reports_running_after_its_start_time_and_trips(tmp_path: Path):
    result = simulate(tmp_path, """
[master]
cycle_ms = 5
[[plant]]
type = "motor"
contactor = "Q 2.3"
running = "I 1.0"
overload = "I 1.1"
start_ms = 250
trip_at_ms = 2000
[[step]]
at_ms = 100
set = { "I 3.3" = 1 }
[[step]]
at_ms = 500
set = { "I 3.3" = 0 }
[[step]]
at_ms = 1000
set = { "I 3.3" = 1 }
[[step]]
at_ms = 3000
""")
    assert changes(result, "I 1.0") == [(0, 0), (350, 1), (500, 0), (1250, 1), (2000, 0)]
    assert changes(result, "I 1.1") == [(0, 0), (2000, 1)]
    assert changes(result, "motor1 state")[-1] == (2000, 3)


def test_a_rule_sets_inputs_once_its_condition_held_long_enough(tmp_path: Path):
    result = simulate(tmp_path, """
[master]
cycle_ms = 5
[[plant]]
type = "rule"
when = "Q 2.0 and not Q 2.1"
after_ms = 100
set = { "I 1.0" = 1, "I 1.2" = 0 }
else = { "I 1.0" = 0, "I 1.2" = 1 }
[[step]]
at_ms = 50
set = { "I 3.0" = 1 }
[[step]]
at_ms = 100
set = { "I 3.1" = 1 }
[[step]]
at_ms = 200
set = { "I 3.1" = 0 }
[[step]]
at_ms = 400
""")
    # held 50..100 (too short), again from 200: set at 300
    assert changes(result, "I 1.0") == [(0, 0), (300, 1)]
    assert changes(result, "I 1.2") == [(0, 1), (300, 0)]


SEQUENCE = Path(__file__).resolve().parents[2] / "demos"


def test_the_sequence_demo_runs_closed_loop_and_its_buggy_twin_fails(tmp_path: Path):
    scenario = SEQUENCE / "sequence.scenario.toml"
    good = CliRunner().invoke(main, ["sim", "--scenario", str(scenario)])
    assert good.exit_code == 0, good.output
    assert ", 0 failed" in good.output
    # the bug: the conveyor starts as soon as the cylinder is out, not once it is back
    text = (SEQUENCE / "sequence.asi").read_text()
    buggy = text.replace("A   I 1.1           ; back in", "A   I 1.0           ; back in")
    assert buggy != text
    (tmp_path / "sequence.asi").write_text(buggy)
    copy = tmp_path / "sequence.scenario.toml"
    copy.write_text(scenario.read_text())
    bad = CliRunner().invoke(main, ["sim", "--scenario", str(copy)])
    assert bad.exit_code == 1, bad.output
    first = bad.output.splitlines()[0]
    assert "at 400 ms: Q 2.1 expected 0, got 1" in first, bad.output


def test_model_lanes_are_in_the_traces_and_runs_are_identical(tmp_path: Path):
    scenario = SEQUENCE / "sequence.scenario.toml"
    outputs = []
    for run in range(2):
        vcd, csv = tmp_path / f"{run}.vcd", tmp_path / f"{run}.csv"
        result = CliRunner().invoke(main, ["sim", "--scenario", str(scenario), "--vcd",
                                           str(vcd), "--csv", str(csv)])
        assert result.exit_code == 0, result.output
        outputs.append((vcd.read_text(), csv.read_text()))
    assert outputs[0] == outputs[1]
    vcd_text, csv_text = outputs[0]
    assert "pusher_position" in vcd_text and "belt_parts" in vcd_text
    assert "pusher position" in csv_text.splitlines()[0]
    chosen = tmp_path / "chosen.csv"
    result = CliRunner().invoke(main, ["sim", "--scenario", str(scenario), "--csv",
                                       str(chosen), "--signals", "belt*,I 1.3"])
    assert result.exit_code == 0, result.output
    assert chosen.read_text().splitlines()[0] == "time_ms,belt parts,belt position,I 1.3"


BAD = [
    ('type = "cylindr"\nextend = "Q 2.0"', 2, 1, "did you mean 'cylinder'"),
    ('type = "cylinder"\nextend = "Q 2.0"\nextended = "Q 1.0"\nstroke_ms = 300', 4, 1,
     "a model drives input or flag bits"),
    ('type = "cylinder"\nextend = "Q 2.0"\nstroke_ms = 300', 1, 1, "has an end switch"),
    ('type = "cylinder"\nextend = "Q 2.0"\nextended = "I 1.0"', 1, 1, "needs stroke_ms"),
    ('type = "cylinder"\nextend = "Q 2.0"\nextended = "I 1.0"\nstroke_ms = 0', 5, 1,
     "stroke_ms is a number above 0"),
    ('type = "cylinder"\nextend = "Q 2.0"\nextended = "I 1.0"\nstroke_ms = 3\nspeed = 1', 6,
     1, "unknown key 'speed'"),
    ('type = "conveyor"\nmotor = "Q 2.1"\nlength_mm = 100\nspeed_mm_s = 10\n'
     'barriers = [ { input = "I 1.3" } ]', 6, 1, "a barrier is"),
    ('type = "conveyor"\nmotor = "Z 2.1"\nlength_mm = 100\nspeed_mm_s = 10', 3, 1,
     "'Z 2.1': 'Z' is not a variable"),
    ('type = "rule"\nwhen = "Q 2.0 and"\nset = { "I 1.0" = 1 }', 3, 18,
     "expected an operand, a number or '(', found the end [E410]"),
    ('type = "rule"\nwhen = "Q 2.0 and \\"X\\" or Q 2.1"\nset = { "I 1.0" = 1 }', 3, 19,
     "unexpected character '\"' [E410]"),
    ('type = "rule"\nwhen = "Q 2.0"\nset = { "Q 1.0" = 1 }', 4, 1, "cannot be set by a rule"),
    ('type = "tank"\nfill = "Q 2.0"\nswitches = [ { input = "I 1.0", at = 500 } ]', 4, 1,
     "at is a number above 0 up to 100"),
    ('type = "motor"\ncontactor = "Q 2.0"\ntrip_at_ms = 5', 4, 1, "needs an overload"),
    ('type = "cylinder"\nextend = "Q 2.0"\nextended = "I 1.0"\nstroke = "300"', 5, 1,
     "stroke: '300' has no unit: give a unit: 300ms or 300s"),
    ('type = "cylinder"\nextend = "Q 2.0"\nextended = "I 1.0"\nstroke_ms = "3s"', 5, 1,
     'stroke_ms is a number of milliseconds; for a time with a unit write stroke = "3s"'),
    ('type = "cylinder"\nextend = "Q 2.0"\nextended = "I 1.0"\nstroke = "3s"\n'
     'stroke_ms = 3', 5, 1, "stroke_ms or stroke, not both"),
    ('type = "conveyor"\nmotor = "Q 2.1"\nlength_mm = 100\nspeed_mm_s = 10\n'
     'parts_at = ["1s", "2"]', 6, 1, "parts_at: '2' has no unit"),
    ('type = "rule"\nwhen = "Q 2.0"\nset = { "I 1.0" = 1 }\nafter = true', 5, 1,
     "after: the time is a number of milliseconds or a text with a unit, not true/false"),
    ('type = "conveyor"\nmotor = "Q 2.1"\nlength_mm = 100\nspeed_mm_s = 10\nbarriers = ['
     + ", ".join(f'{{ input = "F {i // 8}.{i % 8}", at_mm = 1 }}' for i in range(33)) + "]",
     6, 1, "barriers: at most 32, not 33"),
    ('type = "tank"\nfill = "Q 2.0"\nswitches = [ { input = "I 1.0", at = 5 }, '
     '{ input = "I 1.0", at = 50 } ]', 1, 1, "'I 1.0' is driven twice by tank1"),
]


@pytest.mark.parametrize(("table", "line", "column", "message"), BAD)
def test_a_bad_plant_table_is_an_error_at_its_line(tmp_path: Path, table: str, line: int,
                                                  column: int, message: str):
    (tmp_path / "p.asi").write_text(FOLLOW)
    path = tmp_path / "p.scenario.toml"
    path.write_text(f"[master]\ncycle_ms = 5\n[[plant]]\n{table}\n[[step]]\nat_ms = 5\n")
    result = CliRunner().invoke(main, ["sim", "--scenario", str(path)])
    assert result.exit_code == 2, result.output
    where = f"p.scenario.toml:{line + 2}:{column}: error: "
    assert where in result.output and message in result.output, result.output
    assert "^" in result.output and "Traceback" not in result.output


def test_a_step_may_not_set_an_input_a_model_drives(tmp_path: Path):
    (tmp_path / "p.asi").write_text(FOLLOW)
    path = tmp_path / "p.scenario.toml"
    path.write_text('[[plant]]\ntype = "rule"\nwhen = "Q 2.0"\nset = { "I 1.0" = 1 }\n'
                    '[[plant]]\ntype = "rule"\nwhen = "Q 2.1"\nset = { "I 1.0" = 0 }\n'
                    '[[step]]\nat_ms = 5\nset = { "I 3.0" = 1, "I 1.0" = 1 }\n')
    result = CliRunner().invoke(main, ["sim", "--scenario", str(path)])
    assert result.exit_code == 2, result.output
    assert "p.scenario.toml:5:1: error: 'I 1.0' is driven by rule1 already" in result.output
    assert ("p.scenario.toml:11:22: error: 'I 1.0' is driven by the plant model rule1"
            in result.output), result.output


def test_a_command_line_set_may_not_set_an_input_a_model_drives():
    result = CliRunner().invoke(main, ["sim", "--scenario",
                                       str(SEQUENCE / "sequence.scenario.toml"),
                                       "--set", "I 1.2=1", "--set", "I 1.0=1"])
    assert result.exit_code == 2, result.output
    assert "--set 'I 1.0': driven by the plant model pusher" in result.output


def test_a_model_driving_a_slave_that_is_not_on_the_bus_is_an_error(tmp_path: Path):
    (tmp_path / "p.asi").write_text(FOLLOW)
    path = tmp_path / "p.scenario.toml"
    path.write_text('[[step]]\nat_ms = 5\n[[plant]]\ntype = "rule"\nwhen = "Q 2.0"\n'
                    'set = { "I 9.0" = 1 }\n')
    result = CliRunner().invoke(main, ["sim", "--scenario", str(path)])
    assert result.exit_code == 2, result.output
    assert "p.scenario.toml:3:1: error: rule1 drives 'I 9.0' of slave 9" in result.output


def test_model_times_take_a_unit_as_every_duration_does(tmp_path: Path):
    """``stroke = "2s"`` is ``stroke_ms = 2000``; a number there is milliseconds."""
    def model(times: str) -> object:
        text = (f'[[plant]]\ntype = "motor"\ncontactor = "Q 2.0"\nrunning = "I 1.0"\n'
                f'{times}\n[[step]]\nat_ms = 0\n')
        return read_scenario(from_string("s.toml", text)).plants[0]
    a, b = model('start = "1.5s"\ntrip_at = "1min"'), model("start_ms = 1500\ntrip_at = 60000")
    assert (a.start, a.trip_at) == (b.start, b.trip_at) == (1_500_000, 60_000_000)
