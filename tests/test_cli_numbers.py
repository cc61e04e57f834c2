"""Numeric options refuse what is not a finite number: every comparison with NaN is false,
so a bar of ``nan`` would pass every run."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from asictl.cli import main


@pytest.mark.parametrize(("args", "option"), [
    (["test", "demos/blink.scenario.toml", "--coverage-fail-under", "nan"],
     "--coverage-fail-under"),
    (["test", "demos/blink.scenario.toml", "--coverage-fail-under", "inf"],
     "--coverage-fail-under"),
    (["mutate", "demos/blink.scenario.toml", "--min-score", "nan"], "--min-score"),
    (["mutate", "demos/blink.scenario.toml", "--min-score", "-inf"], "--min-score"),
    (["diff", "demos/blink.asi", "demos/blink.asi", "--cycle-ms", "nan"], "--cycle-ms"),
])
def test_a_bar_that_is_no_number_is_refused(args: list[str], option: str) -> None:
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2, result.output
    assert option in result.output
    assert "not a finite number" in result.output


def test_a_finite_bar_still_counts() -> None:
    result = CliRunner().invoke(main, ["test", "demos/blink.scenario.toml",
                                       "--coverage-fail-under", "100.5"])
    assert result.exit_code == 2  # out of range, as before
    result = CliRunner().invoke(main, ["test", "demos/blink.scenario.toml",
                                       "--coverage-fail-under", "1e-9"])
    assert result.exit_code == 0, result.output
