"""The gateway's two-digit 7-segment display (gateway manual, chapter 8).

One rule, computed from what any host can read of a master (phase, mode, slave lists,
profiles), so the emulated gateway's display and ``asictl status`` always agree.
"""

from __future__ import annotations

from collections.abc import Sequence

from asictl.platform.master import SLAVES

DISPLAY_TEXT = {
    40: "the AS-i master is in the offline phase",
    41: "the AS-i master is in the detection phase",
    42: "the AS-i master is in the activation phase",
}


def display_code(
    phase: str, configuration_mode: bool, lps: int, lds: int, pcd: Sequence[int],
    cdi: Sequence[int], turn: int = 0,
) -> int | None:
    """The display for a master state (None: blank).

    ``phase`` is "offline", "detection", "activation" or "normal"; ``lps``/``lds`` are slave
    bit lists (slave n = bit n). Configuration mode shows the detected slaves in turn
    (``turn`` picks which: the gateway shows two a second); protected mode shows the first
    wrongly configured address, else nothing.
    """
    if phase in ("offline", "detection", "activation"):
        return {"offline": 40, "detection": 41, "activation": 42}[phase]
    if configuration_mode:
        detected = [a for a in range(SLAVES) if lds >> a & 1]
        return detected[turn % len(detected)] if detected else None
    for a in range(1, SLAVES):
        projected, present = lps >> a & 1, lds >> a & 1
        if projected != present or (projected and pcd[a] != cdi[a]):
            return a
    return None


def display_text(code: int | None) -> str:
    """What a display code means, in words."""
    if code is None:
        return "blank"
    if code < SLAVES:
        return f"slave {code}"
    return DISPLAY_TEXT.get(code, f"status {code}")
