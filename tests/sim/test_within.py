"""Tolerance windows (``within_ms``): an expectation holds if its value is seen at some
moment within the window, a failure names the IL line that last wrote the operand, and
recordings' scenarios (sim/recording.py) read back as what was recorded."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from asictl.cli import main
from asictl.sim.recording import Sample, choose, slave_operands, to_scenario
from asictl.sim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
ONDELAY = ROOT / "demos" / "ondelay.asi"  # Q 2.0 on 2 s after I 1.0 (10 ms ticks)


def sim(tmp_path: Path, steps: str) -> tuple[int, str]:
    path = tmp_path / "w.scenario.toml"
    path.write_text(f'program = "{ONDELAY}"\n[master]\ncycle_ms = 5\n[[step]]\nat_ms = 100\n'
                    f'set = {{ "I 1.0" = 1 }}\n{steps}')
    result = CliRunner().invoke(main, ["sim", "--scenario", str(path)])
    return result.exit_code, result.output


def test_an_expectation_holds_if_its_value_is_seen_within_the_window(tmp_path: Path):
    # on at 2090..2100 ms: 2060 +- 50 sees it, 2060 +- 20 does not, nor does 2050 exactly
    code, out = sim(tmp_path, '[[step]]\nat_ms = 2060\nwithin_ms = 50\nexpect = { "Q 2.0" = 1 }\n')
    assert code == 0 and "1 expectation, 0 failed" in out, out
    code, out = sim(tmp_path, '[[step]]\nat_ms = 2060\nwithin_ms = 20\nexpect = { "Q 2.0" = 1 }\n')
    assert code == 1, out
    assert "w.scenario.toml:10: at 2060 ms (within 20 ms): Q 2.0 expected 1, got 0; last " \
           "written by ondelay.asi:22" in out, out
    result = CliRunner().invoke(main, ["sim", "--scenario", str(tmp_path / "w.scenario.toml"),
                                       "--json"])
    (failure,) = json.loads(result.stdout)["failures"]
    assert failure["within_ms"] == 20 and failure["last_written_by"] == "ondelay.asi:22"
    # the window looks back, too: off before 2090, so 2150 +- 70 sees the 0 as well
    code, out = sim(tmp_path, '[[step]]\nat_ms = 2150\nwithin_ms = 70\nexpect = { "Q 2.0" = 0 }\n')
    assert code == 0, out


def test_a_window_at_the_start_sees_the_first_cycles(tmp_path: Path):
    code, out = sim(tmp_path, '[[step]]\nat_ms = 0\nwithin_ms = 10\nexpect = { "I 1.0" = 0, '
                              '"T 2" = 0 }\n')
    assert code == 0, out


def test_a_bad_window_is_an_error_at_its_line(tmp_path: Path):
    code, out = sim(tmp_path, '[[step]]\nat_ms = 60\nwithin_ms = -1\nexpect = { "Q 2.0" = 0 }\n')
    assert code == 2 and "w.scenario.toml:9:13: error: within_ms is a time" in out, out
    code, out = sim(tmp_path, '[[step]]\nat_ms = 60\nwithin_ms = 5\n')
    assert code == 2 and "the step has none" in out, out


def test_a_recording_reads_back_as_set_steps_and_windowed_expectations(tmp_path: Path):
    inputs, outputs = slave_operands({4: 0x0, 17: 0x8, 6: 0x7})  # iiii, oooo, bbbb
    assert inputs == [*(f"I 4.{b}" for b in range(4)), *(f"I 6.{b}" for b in range(4))]
    assert outputs == [*(f"Q 6.{b}" for b in range(4)), *(f"Q 17.{b}" for b in range(4))]
    chosen = choose(inputs, outputs, ["I 4.0", "Q 17.*", "F 1.2"])
    assert chosen == (["I 4.0"], [*(f"Q 17.{b}" for b in range(4)), "F 1.2"])
    samples = [Sample(0, {"I 4.0": 0, "Q 17.3": 0}), Sample(20.4, {"I 4.0": 0, "Q 17.3": 0}),
               Sample(40.6, {"I 4.0": 1, "Q 17.3": 0}), Sample(61, {"I 4.0": 1, "Q 17.3": 1})]
    text = to_scenario(samples, ["I 4.0"], ["Q 17.3"], 30, program="or.asi",
                       comment="a test\nof two lines")
    assert text.startswith("# a test\n# of two lines\nprogram = \"or.asi\"\n")
    path = tmp_path / "r.scenario.toml"
    path.write_text(text)
    scenario = load_scenario(path)
    steps = [(s.at_ms, [(str(o), v) for o, v, _ in s.set],
              [(str(o), v) for o, v, _ in s.expect], s.within_ms) for s in scenario.steps]
    assert steps == [(0, [("I 4.0", 0)], [("Q 17.3", 0)], 30), (41, [("I 4.0", 1)], [], 0),
                     (61, [], [("Q 17.3", 1)], 30)]
