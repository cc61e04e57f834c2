"""A launch's ``duration`` is read as every duration is: a text with its unit, a number
of milliseconds; a text without a unit is refused with both readings."""

from __future__ import annotations

from pathlib import Path

import pytest

from asictl.dap.simulated import launch
from asictl.errors import UserError


@pytest.mark.parametrize(("duration", "message"), [
    ("16", "duration: '16' has no unit: give a unit: 16ms or 16s"),
    ("25h", "duration: '25h' is longer than the longest allowed, 24 h 0 min"),
    (True, "duration: a duration is a number of milliseconds or a text with a unit"),
])
def test_a_launch_duration_without_a_unit_is_refused(tmp_path: Path, duration: object,
                                                     message: str) -> None:
    with pytest.raises(UserError) as refused:
        launch({"program": str(tmp_path / "p.asi"), "duration": duration},  # type: ignore[dict-item]
               lambda _: None)
    assert str(refused.value).startswith(message)
