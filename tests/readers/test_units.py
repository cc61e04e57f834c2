"""Durations are read one way: a text carries its unit, a number is milliseconds."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from asictl.readers.units import (
    UNIT_MS,
    Cycles,
    UnitError,
    duration_ms,
    format_duration,
    parse_cycles,
    parse_duration,
    timer_ticks,
)


@pytest.mark.parametrize(("text", "ms"), [
    ("16ms", 16), ("16 ms", 16), ("2s", 2000), ("1.5s", 1500), ("2min", 120_000),
    ("2m", 120_000), ("1h", 3_600_000), ("500us", 0.5), ("0", 0), ("10S", 10_000),
])
def test_texts_with_units(text: str, ms: float) -> None:
    assert parse_duration(text) == ms


def test_a_bare_number_in_a_text_shows_both_readings() -> None:
    with pytest.raises(UnitError, match=r"give a unit: 16ms or 16s"):
        parse_duration("16")


@pytest.mark.parametrize("text", ["", "ms", "16 parsecs", "-1s", "1e3s", "x" * 200])
def test_what_is_not_a_duration(text: str) -> None:
    with pytest.raises(UnitError):
        parse_duration(text)


def test_numbers_from_files_are_milliseconds() -> None:
    assert duration_ms(16) == 16.0
    assert duration_ms(2.5) == 2.5
    assert duration_ms("16s") == 16_000.0
    for bad in (True, -1, math.nan, math.inf, [1], None):
        with pytest.raises(UnitError):
            duration_ms(bad)


def test_the_limit_is_said_in_a_readable_time() -> None:
    with pytest.raises(UnitError, match=r"longer than the longest allowed, 24 h 0 min"):
        parse_duration("25h", limit_ms=24 * 3_600_000)


def test_timer_ticks_round_up_to_whole_10ms_ticks() -> None:
    assert [timer_ticks(ms) for ms in (0, 1, 9, 10, 11, 20000)] == [0, 1, 1, 1, 2, 2000]


@given(st.integers(min_value=0, max_value=10**9))
def test_timer_ticks_cover_the_time_with_less_than_one_tick_to_spare(ms: int) -> None:
    ticks = timer_ticks(ms)
    assert ticks * 10 >= ms > (ticks - 1) * 10 or ms == ticks == 0


@given(st.integers(min_value=0, max_value=10**7), st.sampled_from(sorted(UNIT_MS)))
def test_every_unit_reads_back_its_own_value(number: int, unit: str) -> None:
    assert parse_duration(f"{number}{unit}") == pytest.approx(number * UNIT_MS[unit])


@pytest.mark.parametrize(("ms", "text"), [
    (0.5, "500 µs"), (250, "250 ms"), (24816.1, "24.8 s"), (119_999, "2 min 0 s"),
    (7.2e6, "2 h 0 min"),
])
def test_format_duration(ms: float, text: str) -> None:
    assert format_duration(ms) == text


@pytest.mark.parametrize(("text", "found"), [
    ("25", Cycles(count=25)), ("25 cycles", Cycles(count=25)), ("1 cycle", Cycles(count=1)),
    ("25s", Cycles(ms=25_000)), ("250ms", Cycles(ms=250)),
])
def test_a_depth_is_cycles_or_a_time(text: str, found: Cycles) -> None:
    assert parse_cycles(text) == found


def test_a_time_is_turned_into_cycles_rounded_up() -> None:
    assert parse_cycles("25s").of(5) == 5000
    assert parse_cycles("26ms").of(5) == 6
    assert parse_cycles("0.3s").of(0.1) == 3000  # no float error adds a cycle
    assert parse_cycles("25").of(5) == 25
    with pytest.raises(UnitError, match="25 s is 5000 cycles of 5 ms, more than 1000"):
        parse_cycles("25s").of(5, most=1000)
    with pytest.raises(UnitError, match="not a number of cycles or a time"):
        parse_cycles("soon")
