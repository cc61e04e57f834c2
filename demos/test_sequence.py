"""sequence.asi tested from Python (``pytest demos/``): the cylinder is a plant model
written here, called after every program cycle; the conveyor is the scenario's model.
docs/testing.md explains the API."""

from __future__ import annotations

from pathlib import Path

import pytest

from asictl.testing import ExpectationFailed, Plc

HERE = Path(__file__).parent
STROKE_MS = 300.0


def couple(plc: Plc) -> None:
    """The cylinder in Python (spring return), the conveyor as in the scenario."""
    position = 0.0  # ms of stroke out

    def cylinder(elapsed_ms: float) -> None:
        nonlocal position
        if plc["Q 2.0"]:
            position = min(STROKE_MS, position + elapsed_ms)
        else:
            position = max(0.0, position - elapsed_ms)
        plc["I 1.0"] = position >= STROKE_MS
        plc["I 1.1"] = position <= 0

    plc["I 1.1"] = 1  # retracted at the start
    plc.on_cycle(cylinder)
    plc.add_plant("conveyor", motor="Q 2.1", length_mm=1000, speed_mm_s=500,
                  parts_at_ms=[0], barriers=[{"input": "I 1.3", "at_mm": 800}])


def test_the_sequence_pushes_then_conveys_to_the_barrier(asictl_plc):
    plc = asictl_plc(HERE / "sequence.asi", cycle_ms=5)
    couple(plc)
    plc["I 1.2"] = 1  # start
    plc.run("50ms")
    plc["I 1.2"] = 0
    plc.expect("Q 2.0", 1)  # extending
    out = plc.run_until("Q 2.0 == 0", timeout="1s")
    assert 300 <= out <= 310  # the stroke and a cycle
    conveying = plc.run_until("Q 2.1", timeout="1s")
    assert conveying - out >= STROKE_MS  # only once the cylinder is back
    done = plc.run_until("Q 2.2 and not Q 2.1", timeout="3s")
    assert 1600 <= done - conveying <= 1610  # 800 mm at 500 mm/s
    plc.expect("I 1.3", 1)


def test_a_conveyor_that_starts_before_the_cylinder_is_back_fails(asictl_plc, tmp_path):
    source = (HERE / "sequence.asi").read_text()
    buggy = source.replace("A   I 1.1           ; back in", "A   I 1.0           ; back in")
    (tmp_path / "buggy.asi").write_text(buggy)
    plc = asictl_plc(tmp_path / "buggy.asi", cycle_ms=5)
    couple(plc)
    plc["I 1.2"] = 1
    plc.run_until("Q 2.0 == 0", timeout="1s")
    plc.run("10ms")
    with pytest.raises(ExpectationFailed, match=r"at 31\d ms: Q 2.1 expected 0, got 1"):
        plc.expect("Q 2.1", 0)
