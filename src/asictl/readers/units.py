"""Durations, read one way everywhere: a number with its unit (``16ms``, ``2s``, ``1.5min``,
``1h``), or a bare number in the one documented unit, the millisecond.

Why one module: a duration used to mean different things by how it was spelt (a TOML
integer was milliseconds, the same digits in a string were seconds), and a wrong guess
ran silently. Here a *text* without a unit is never guessed: it is refused with both
readings shown, so the user picks one. A *number* (a TOML integer or float, a Python
``int``) is milliseconds, as the master counts its timers (``KT`` is in ms).

The master's timers tick every 10 ms; ``timer_ticks`` is the one place that rounds a
time in milliseconds up to whole ticks, as the firmware loads ``L KT n``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

#: Milliseconds per unit. ``m`` is the minute (as systemd's time spans read it).
UNIT_MS: dict[str, float] = {
    "us": 0.001, "µs": 0.001,
    "ms": 1.0,
    "s": 1000.0, "sec": 1000.0,
    "m": 60_000.0, "min": 60_000.0,
    "h": 3_600_000.0,
}
#: The master's timer tick: every timer counts down once per 10 ms.
TICK_MS = 10

_DURATION = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*([a-zµ]*)\s*$", re.IGNORECASE)


class UnitError(ValueError):
    """A duration that cannot be read; the message says how to write it."""


def parse_duration(text: str, *, what: str = "a duration", limit_ms: float | None = None) -> float:
    """``text`` with its unit to milliseconds; a bare number other than 0 is refused with
    both readings ("give a unit: 16ms or 16s"), since nothing tells which was meant."""
    if not isinstance(text, str):
        raise UnitError(f"{what} is a number with a unit, such as 250ms or 10s")
    match = _DURATION.match(text) if len(text) < 100 else None
    if not match:
        raise UnitError(f"'{_short(text)}' is not {what} (write a number and a unit: "
                        "250ms, 10s, 2min, 1h)")
    number, unit = match[1], match[2].lower()
    if not unit:
        if float(number) == 0:
            return 0.0
        raise UnitError(f"'{text.strip()}' has no unit: give a unit: {number}ms or {number}s")
    if unit not in UNIT_MS:
        raise UnitError(f"'{text.strip()}': unknown unit '{match[2]}' "
                        f"(units: {', '.join(u for u in UNIT_MS if u != 'µs')})")
    return _checked(float(number) * UNIT_MS[unit], text.strip(), limit_ms)


def duration_ms(value: object, *, what: str = "a duration",
                limit_ms: float | None = None) -> float:
    """A duration from a file: a number is milliseconds, a text carries its unit."""
    if isinstance(value, bool):
        raise UnitError(f"{what} is a number of milliseconds or a text with a unit, "
                        "not true/false")
    if isinstance(value, int | float):
        if not math.isfinite(value) or value < 0:
            raise UnitError(f"{what} must be a finite time of 0 ms or more")
        return _checked(float(value), f"{value} ms", limit_ms)
    if isinstance(value, str):
        return parse_duration(value, what=what, limit_ms=limit_ms)
    raise UnitError(f"{what} is a number of milliseconds or a text with a unit, such as '10s'")


def timer_ticks(ms: int) -> int:
    """The 10 ms ticks a timer loaded with ``ms`` milliseconds counts (rounded up)."""
    return (ms + TICK_MS - 1) // TICK_MS


def _checked(ms: float, text: str, limit_ms: float | None) -> float:
    if not math.isfinite(ms):
        raise UnitError(f"'{_short(text)}' is not a finite time")
    if limit_ms is not None and ms > limit_ms:
        raise UnitError(f"'{_short(text)}' is longer than the longest allowed, "
                        f"{format_duration(limit_ms)}")
    return ms


def format_duration(ms: float) -> str:
    """A time as a person reads it: ``250 ms``, ``24.8 s``, ``2 h 0 min``."""
    if ms < 1:
        return f"{ms * 1000:.3g} µs"
    if ms < 1000:
        return f"{ms:.4g} ms"
    if ms < 60_000:
        return f"{ms / 1000:.3g} s"
    seconds = round(ms / 1000)
    if seconds < 3600:
        return f"{seconds // 60} min {seconds % 60} s"
    minutes = round(ms / 60_000)
    return f"{minutes // 60} h {minutes % 60} min"


def format_instant(ms: float) -> str:
    """A point in (master or scenario) time, exact as a scenario writes it: ``250 ms``,
    and from a minute on also as a person reads it: ``2 h 0 min (7200000 ms)``, where
    ``{ms:g}`` printed ``7.2e+06 ms``."""
    exact = f"{ms:.10g} ms"
    return exact if ms < 60_000 else f"{format_duration(ms)} ({exact})"


def _short(text: str) -> str:
    return text if len(text) <= 40 else text[:37] + "..."


@dataclass(frozen=True)
class Cycles:
    """A number of program cycles, given as a count (``25``, ``25 cycles``) or as a time
    with its unit (``25s``) that the program's cycle time turns into a count."""

    count: int | None = None
    ms: float | None = None

    def of(self, cycle_ms: float, *, most: int | None = None) -> int:
        """The count; a time is divided by ``cycle_ms`` and rounded up. More than
        ``most`` is a ``UnitError``."""
        if self.count is not None:
            count = self.count
        else:
            assert self.ms is not None
            count = math.ceil(round(self.ms / cycle_ms, 9))
        if most is not None and count > most:
            raise UnitError(f"{self} is {count} cycles of {cycle_ms:g} ms, more than {most}")
        return count

    def __str__(self) -> str:
        return f"{self.count} cycles" if self.count is not None else format_duration(
            self.ms or 0.0)


def parse_cycles(text: str) -> Cycles:
    """A whole number (or ``N cycles``) is a count of cycles; anything else is a time with
    its unit, as ``parse_duration`` reads it."""
    match = _CYCLES.match(text) if len(text) < 100 else None
    if match:
        return Cycles(count=int(match[1]))
    return Cycles(ms=parse_duration(text, what="a number of cycles or a time"))


_CYCLES = re.compile(r"^\s*(\d+)\s*(?:cycles?)?\s*$", re.IGNORECASE)
