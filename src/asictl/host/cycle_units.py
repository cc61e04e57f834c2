"""The control program's cycle times (DPRAM 300h-303h) and the unit the sources disagree
on.

The PC2 manual's DPRAM table gives no unit; asictl's design reads them in 10 µs
(platform.pc2.CYCLE_TIME_UNIT_US), while a vendor driver header for these masters
documents 10 ms. Until a probe of a real board decides (docs/verify.md "Bring-up on a
real board"), ``status`` and ``probe`` show the raw value and both readings.
"""

from __future__ import annotations

from asictl.platform.pc2 import CYCLE_TIME_UNIT_US
from asictl.readers.units import format_duration

#: The unit a vendor driver header gives the cycle times: 10 ms.
OTHER_UNIT_US = 10_000


def raw_value(ms: float) -> int:
    """The raw 16-bit value behind a cycle time read in asictl's unit."""
    return round(ms * 1000 / CYCLE_TIME_UNIT_US)


def cycle_text(previous_ms: float, maximum_ms: float) -> str:
    """The last and longest cycle as ``status`` and the monitor print them: in µs below a
    millisecond (a program's cycles take 10-40 µs, which one decimal of ms showed as 0.0)."""
    return f"{format_duration(previous_ms)} (max {format_duration(maximum_ms)})"


def readings(raw: int) -> dict[str, float]:
    """Both readings of one raw value, in milliseconds."""
    return {"ms_if_10us": raw * CYCLE_TIME_UNIT_US / 1000, "ms_if_10ms": raw * OTHER_UNIT_US / 1000}


def other_reading(previous: int, maximum: int) -> str:
    """The raw values and the reading in the other unit, as ``status`` adds them."""
    return (f"raw {previous:04X}h (max {maximum:04X}h); in 10 ms units, as a vendor driver "
            f"header documents them: {previous * OTHER_UNIT_US / 1000:.0f} ms "
            f"(max {maximum * OTHER_UNIT_US / 1000:.0f} ms); the unit is unconfirmed until a "
            "probe of a real board decides")
