"""A response's ``within`` is cycles or a time with its unit; a bare number is refused
with both readings, at the value."""

from __future__ import annotations

import pytest

from asictl.diagnostics import DiagnosticError
from asictl.prove.props import read_properties
from asictl.source import from_string


def _property(within: str):
    text = ('[[property]]\nname = "p"\nwhen = "I 1.0"\nthen = "Q 2.0"\n'
            f"within = {within}\n")
    return read_properties(from_string("p.props.toml", text)).properties[0]


@pytest.mark.parametrize(("within", "cycles", "ms"), [
    ('"3 cycles"', 3, None), ('"1 cycle"', 1, None), ('"50ms"', None, 50.0),
    ('"2s"', None, 2000.0),
])
def test_within_is_cycles_or_a_time(within: str, cycles: int | None, ms: float | None):
    found = _property(within)
    assert (found.within_cycles, found.within_ms) == (cycles, ms)


@pytest.mark.parametrize(("within", "message"), [
    ("3", 'within: give a unit: "3 cycles" or "3ms"'),
    ('"3"', 'within: give a unit: "3 cycles" or "3ms"'),
    ('"20000 cycles"', "within: at most 10000 cycles"),
    ('"soon"', "within: 'soon' is not a number of cycles or a time"),
])
def test_a_within_without_a_unit_is_refused_at_its_value(within: str, message: str):
    with pytest.raises(DiagnosticError) as caught:
        _property(within)
    (found,) = caught.value.diagnostics
    assert str(found.span) == "p.props.toml:5:10" and found.message.startswith(message)
