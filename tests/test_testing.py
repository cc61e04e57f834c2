"""asictl.testing, the Python test API: time as the scenarios' contract has it, Python
plant models after every program cycle, the scenario models, failures as scenario
lines, traces, and the pytest fixture ``asictl_plc``."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from asictl.errors import UserError
from asictl.observe.condition import ConditionError
from asictl.testing import ExpectationFailed, LoadError, Plc, TimedOut

ROOT = Path(__file__).resolve().parent.parent
DEMOS = ROOT / "demos"
ONDELAY = DEMOS / "ondelay.asi"
PLUGIN = ("-p", "asictl.pytest_plugin")


def test_a_set_before_time_passes_is_seen_by_the_first_cycle():
    with Plc.load(DEMOS / "logic.asi", cycle_ms=5) as plc:
        assert plc.time_ms == 0
        text = (DEMOS / "logic.scenario.toml").read_text()
        assert '"I 1.0" = 1' in text  # logic.asi: Q 2.0 = I 1.0 and I 1.1
        plc.set("I 1.0", 1)
        plc.set("I 1.1", 1)
        plc.run(0.001)  # the first cycle, at time 0
        assert plc["Q 2.0"] == 1
        assert plc.time_ms == 0.001


def test_run_until_returns_when_the_condition_holds_after_a_cycle():
    plc = Plc.load(ONDELAY, cycle_ms=5)
    plc.run("100ms")
    plc["I 1.0"] = 1
    at = plc.run_until("Q 2.0 == 1", timeout="3s")
    # the timer's 2 s in 10 ms ticks from the cycle at 100 ms; whole cycles of 5 ms
    assert 2090 <= at <= 2105 and at % 5 == 0
    assert plc.time_ms == at
    assert plc.run_until("Q 2.0", timeout=0) == at  # holds already: no time passes


def test_a_time_out_shows_the_trace_of_the_wait():
    plc = Plc.load(ONDELAY, cycle_ms=5)
    plc["I 1.0"] = 1
    with pytest.raises(TimedOut) as caught:
        plc.run_until("Q 2.0 == 1 and T 2", timeout="1s")
    text = str(caught.value)
    first = text.splitlines()[0]
    assert re.fullmatch(r"test_testing\.py:\d+: at 1000 ms: 'Q 2\.0 == 1 and T 2' did not "
                        r"hold within 1 s \(from 0 ms\)", first), first
    assert "time_ms,Q 2.0,T 2" in text.splitlines()  # what it waited for, the outputs
    assert caught.value.trace.end_ms == 1000


def test_an_expectation_fails_as_a_scenario_line():
    plc = Plc.load(ONDELAY, cycle_ms=5)
    plc["I 1.0"] = 1
    plc.run("250ms")
    plc.expect("Q 2.0", 0)
    with pytest.raises(ExpectationFailed) as caught:
        plc.expect("Q 2.0", 1)
    assert re.fullmatch(r"test_testing\.py:\d+: at 250 ms: Q 2\.0 expected 1, got 0",
                        str(caught.value))


def test_times_past_a_minute_read_as_people_read_them():
    """``at 7.2e+06 ms`` once: a time from a minute on as hours and minutes, the exact
    milliseconds beside it; a wait as a duration."""
    plc = Plc.load(ONDELAY, cycle_ms=5)
    plc.run("2h")
    with pytest.raises(ExpectationFailed) as caught:
        plc.expect("Q 2.0", 1)
    assert re.fullmatch(r"test_testing\.py:\d+: at 2 h 0 min \(7200000 ms\): Q 2\.0 "
                        r"expected 1, got 0", str(caught.value))
    with pytest.raises(TimedOut) as waited:
        plc.run_until("Q 2.0", timeout="24.8s")
    assert re.match(r"test_testing\.py:\d+: at 2 h 0 min \(7224800 ms\): 'Q 2\.0' did not "
                    r"hold within 24\.8 s \(from 2 h 0 min \(7200000 ms\)\)",
                    str(waited.value)), str(waited.value)


def test_on_cycle_is_called_after_every_program_cycle_with_the_elapsed_time():
    plc = Plc.load(ONDELAY, cycle_ms=5)
    calls: list[tuple[float, float]] = []
    plc.on_cycle(lambda elapsed: calls.append((plc.time_ms, elapsed)))
    plc.run("50ms")
    assert calls == [(0.0, 0.0)] + [(5.0 * k, 5.0) for k in range(1, 11)]
    plc.run("2.5ms")
    assert calls[-1] == (50.0, 5.0) and plc.time_ms == 52.5
    seen: list[tuple[Plc, float]] = []
    plc.on_cycle(lambda given, elapsed: seen.append((given, elapsed)))  # the Plc too
    plc.run("10ms")
    assert seen == [(plc, 2.5), (plc, 5.0)]  # counted from when it was added


def test_a_python_plant_model_closes_the_loop():
    """ondelay's input follows its own output back, 100 ms later: Q 2.0 on makes I 1.0
    off, which makes Q 2.0 off at once."""
    plc = Plc.load(ONDELAY, cycle_ms=5)
    since: list[float] = []

    def plant(elapsed: float) -> None:
        if plc["Q 2.0"]:
            since.append(plc.time_ms)
        if since and plc.time_ms - since[0] >= 100:
            plc["I 1.0"] = 0

    plc.on_cycle(plant)
    plc["I 1.0"] = 1
    on = plc.run_until("Q 2.0", timeout="3s")
    off = plc.run_until("not Q 2.0", timeout="1s")
    assert off - on == 105  # 100 ms later the input goes, the next cycle sees it


def test_scenario_models_from_python_and_their_lanes_in_the_trace(tmp_path: Path):
    plc = Plc.load(DEMOS / "sequence.asi", cycle_ms=5)
    cylinder = plc.add_plant("cylinder", name="pusher", extend="Q 2.0", extended="I 1.0",
                             retracted="I 1.1", stroke_ms=300)
    plc.add_plant("conveyor", motor="Q 2.1", length_mm=1000, speed_mm_s=500,
                  parts_at_ms=[0], barriers=[{"input": "I 1.3", "at_mm": 800}])
    with pytest.raises(ValueError, match="driven by the plant model pusher"):
        plc.set("I 1.1", 0)
    plc["I 1.2"] = 1
    plc.run("160ms")
    assert cylinder.position == pytest.approx(160 / 300)  # out from the first cycle
    done = plc.run_until("Q 2.2", timeout="5s")
    # out at 300 ms, back at 600, then 1.6 s of conveyor run: each switch is seen by the
    # cycle at the moment it closes
    assert done == 2200
    vcd = tmp_path / "run.vcd"
    trace = plc.trace(vcd=vcd, csv=tmp_path / "run.csv")
    assert "pusher_position" in vcd.read_text()
    assert "conveyor1 parts" in (tmp_path / "run.csv").read_text().splitlines()[0]
    assert trace.end_ms == done
    with pytest.raises(UserError):
        plc.trace(csv=DEMOS / "sequence.asi")  # never over the program


def test_bad_arguments_say_what_is_wrong(tmp_path: Path):
    plc = Plc.load(ONDELAY, cycle_ms=5, symbols={"Start": "I 1.0", "Lamp": "Q 2.0"})
    plc["Start"] = 1
    assert plc["I 1.0"] == 1 and plc["Lamp"] == 0
    with pytest.raises(ValueError, match="cannot be set"):
        plc.set("Q 2.0", 1)
    with pytest.raises(ValueError, match="out of range"):
        plc.set("I 1.0", 2)
    with pytest.raises(ValueError, match="unknown key 'strok'"):
        plc.add_plant("cylinder", extend="Q 2.0", extended="I 1.1", strok=3)
    with pytest.raises(ConditionError, match="expected an operand, a number or '\\(', found 'or'"
                       ) as caught:
        plc.run_until("Q 2.0 and or I 1.0")
    assert caught.value.offset == 10
    with pytest.raises(ValueError, match="not a duration"):
        plc.run("soon")
    plc.close()
    with pytest.raises(RuntimeError, match="closed"):
        plc.run("1ms")
    broken = tmp_path / "broken.asi"
    broken.write_text("[PROGRAM]\n        A   X 1.0\n")
    with pytest.raises(LoadError, match=r"broken\.asi:2:\d+: error"):
        Plc.load(broken)
    with pytest.raises(ValueError, match="slave 40"):
        Plc.load(ONDELAY, slaves={40: "iiii,0"})


@pytest.mark.parametrize("value", [0.5, 1.7, -0.25])
def test_a_fraction_is_refused_never_cut_off(value: float):
    with Plc.load(DEMOS / "logic.asi", cycle_ms=5) as plc:
        with pytest.raises(ValueError, match=r"'I 1\.0' takes a whole number, not "
                           + re.escape(repr(value))):
            plc.set("I 1.0", value)
        with pytest.raises(TypeError, match=r"'I 1\.0' takes a whole number, not str"):
            plc["I 1.0"] = "1"  # type: ignore[assignment]
        plc["I 1.0"] = 1.0  # a float that is a whole number is that number
        assert plc["I 1.0"] == 1
        with pytest.raises(ValueError, match=r"'I 1\.0' takes a whole number"):
            plc.expect("I 1.0", 0.5)  # would have expected 0


@pytest.mark.parametrize("slaves", ["x", ["iiii,0"], 16])
def test_slaves_that_are_no_mapping_are_a_type_error(slaves: object):
    with pytest.raises(TypeError, match="slaves is a mapping"):
        Plc.load(ONDELAY, slaves=slaves)  # type: ignore[arg-type]


@pytest.mark.parametrize("call", ["run", "run_until"])
def test_a_plant_model_that_lets_time_pass_is_refused(call: str):
    with Plc.load(ONDELAY, cycle_ms=5) as plc:
        @plc.on_cycle
        def model(plc: Plc, elapsed_ms: float) -> None:
            if call == "run":
                plc.run("5ms")
            else:
                plc.run_until("Q 2.0")

        with pytest.raises(RuntimeError, match=r"plant model .* cannot let time pass"):
            plc.run("20ms")


def test_two_plant_models_with_one_name_are_refused():
    with Plc.load(DEMOS / "sequence.asi", cycle_ms=5) as plc:
        plc.add_plant("cylinder", name="pusher", extend="Q 2.0", extended="I 1.0",
                      stroke_ms=300)
        with pytest.raises(ValueError, match="named 'pusher' already"):
            plc.add_plant("cylinder", name="pusher", extend="Q 2.1", extended="I 1.3",
                          stroke_ms=300)


def test_a_name_with_an_escape_sequence_is_escaped_in_the_csv(tmp_path: Path):
    with Plc.load(DEMOS / "sequence.asi", cycle_ms=5) as plc:
        plc.add_plant("cylinder", name="p\x1b[31mred\x07", extend="Q 2.0",
                      extended="I 1.0", stroke_ms=300)
        plc.run("10ms")
        plc.trace(csv=tmp_path / "run.csv")
    header = (tmp_path / "run.csv").read_text().splitlines()[0]
    assert "\x1b" not in header and "\x07" not in header
    assert "p\\x1b[31mred\\x07 position" in header


def test_the_fixture_makes_plcs_closed_after_the_test(pytester: pytest.Pytester,
                                                       monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv("PYTEST_DISABLE_PLUGIN_AUTOLOAD", "1")
    pytester.path.joinpath("ondelay.asi").write_text(ONDELAY.read_text())
    pytester.makepyfile(test_delay="""
        kept = []

        def test_on_after_two_seconds(asictl_plc):
            plc = asictl_plc("ondelay.asi", cycle_ms=5)
            kept.append(plc)
            plc["I 1.0"] = 1
            plc.run("2200ms")
            plc.expect("Q 2.0", 1)

        def test_the_plc_is_closed_afterwards():
            try:
                kept[0].run("1ms")
            except RuntimeError as exc:
                assert "closed" in str(exc)
            else:
                raise AssertionError("not closed")

        def test_too_early(asictl_plc):
            plc = asictl_plc("ondelay.asi")
            plc["I 1.0"] = 1
            plc.run("1s")
            plc.expect("Q 2.0", 1)
    """)
    result = pytester.runpytest(*PLUGIN, "-p", "no:cacheprovider")
    result.assert_outcomes(passed=2, failed=1)
    result.stdout.fnmatch_lines(["*test_delay.py:22: at 1000 ms: Q 2.0 expected 1, got 0*"])
