"""The gateway's front panel: its four-digit display and its seven LEDs (gateway manual,
4.1 line 125, 4.2 and chapter 8).

The codes and what they mean, the LEDs and the rule each follows, and the display a
master's state alone gives (``display_code``): the emulated gateway's panel
(``gateway.panel``) adds what only the gateway knows (its keys, the order in which it
found the configuration errors, the messages it latches), and ``asictl status`` uses the
rule here for a master reached without its panel, so that both always agree on what a
state looks like. docs/modbus.md has the table with the manual's lines.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from asictl.platform.gateway import BAUD_RATES, FRAMINGS
from asictl.platform.master import SLAVES
from asictl.platform.pc2 import EcFlag

#: A short AS-i power failure caused the last short-time configuration error (5.3.2).
POWER_FAIL = 39
OFFLINE = 40
DETECTION = 41
ACTIVATION = 42
NORMAL_START = 43
LEAVE_REFUSED = 80
ADDRESS_ERROR = 81
KEYS_LOCKED = 82
PROGRAM_COPY = 83
#: The display test at power-up: every segment and every LED lit for about a second (222).
SELF_TEST = 88
NO_SLAVE_ZERO = 90
TARGET_TAKEN = 91
NOT_SET = 92
NOT_STORED = 93
WRONG_PROFILE = 94
SURPLUS_SLAVE = 95

#: Chapter 8's table (lines 1349-1386) and 5.3.2's 39 (line 306), in English.
DISPLAY_TEXT = {
    POWER_FAIL: "the last short-time configuration error was a short AS-i power failure",
    OFFLINE: "the AS-i master is in the offline phase",
    DETECTION: "the AS-i master is in the detection phase",
    ACTIVATION: "the AS-i master is in the activation phase",
    NORMAL_START: "the AS-i master starts normal operation",
    70: "hardware error: the AS-i master's EEPROM cannot be written",
    72: "hardware error: no connection to the PIC processor",
    73: "hardware error: no connection to the PIC processor",
    74: "checksum error in the EEPROM",
    75: "error in the internal RAM",
    76: "error in the external RAM",
    LEAVE_REFUSED: "error leaving configuration mode: there is a slave with address 0",
    ADDRESS_ERROR: "general error changing a slave address",
    KEYS_LOCKED: "the keys are locked: until the master restarts, only the host can "
    "operate it (Modbus register 1007)",
    PROGRAM_COPY: "the control program is being read from the EEPROM and copied into RAM",
    SELF_TEST: "display test at the AS-i master's start-up",
    NO_SLAVE_ZERO: "error changing a slave address in protected mode: there is no slave "
    "with address 0",
    TARGET_TAKEN: "error changing a slave address: the target address is taken",
    NOT_SET: "error changing a slave address: the new address could not be set",
    NOT_STORED: "error changing a slave address: the slave could store the new address "
    "only volatile",
    WRONG_PROFILE: "error changing a slave address in protected mode: the slave has the "
    "wrong configuration data",
    SURPLUS_SLAVE: "error changing a slave address in protected mode: the configuration "
    "error is a surplus slave, not a missing one",
}
#: The codes only real hardware shows: its own faults.
HARDWARE_ONLY = frozenset({70, 72, 73, 74, 75, 76})
#: The display has four digits ("vierstellige Sieben-Segment-Anzeige", 4.1 line 125); the
#: codes and addresses are two digits, in the right two, and the test lights all four.
DIGITS = 4

#: The LEDs, left to right as 4.2 lists them (lines 140-147), and their labels.
LEDS = {
    "power": "power",
    "ser_active": "ser active",
    "config_err": "config err",
    "u_asi": "U AS-i",
    "asi_active": "AS-i active",
    "prg_enable": "prg enable",
    "prj_mode": "prj mode",
}


@dataclass(frozen=True)
class Display:
    """What the display shows: a code (None: blank), whether it blinks, and what it means
    here (the same digits mean a slave, a free address or a baud rate by the situation)."""

    code: int | None
    meaning: str = "blank"
    blinking: bool = False

    @property
    def text(self) -> str:
        """The four digits as they light up: "  07" (a code in the right two), "8888"
        (the display test), or "" when blank."""
        if self.code is None:
            return ""
        if self.code == SELF_TEST:
            return "8" * DIGITS
        return f"{self.code:02d}".rjust(DIGITS)

    def to_json(self) -> dict[str, Any]:
        return {
            "code": self.code, "text": self.text, "blinking": self.blinking,
            "meaning": self.meaning,
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Display:
        code = data.get("code")
        return cls(
            code if isinstance(code, int) else None, str(data.get("meaning", "blank")),
            bool(data.get("blinking", False)),
        )

    def shown(self) -> str:
        """One line: ``07 blinking (the target address ...)`` or ``blank`` (the digits
        lit, without the dark ones before them)."""
        if self.code is None:
            return "blank"
        return f"{self.text.lstrip()}{' blinking' if self.blinking else ''} ({self.meaning})"


def leds(ec_flags: int, *, ser_active: bool, power: bool = True) -> dict[str, bool]:
    """The seven LEDs for a master's execution control flags (4.2, lines 140-147).

    config err is lit for a configuration error and also while no Modbus communication
    runs (line 143: "oder es findet keine Kommunikation über den Modbus statt"); U AS-i is
    the flag APO (not APF), AS-i active normal operation, prg enable Auto_Address_Available,
    prj mode Configuration_Active.
    """
    return {
        "power": power,
        "ser_active": ser_active,
        "config_err": not ec_flags & EcFlag.CONFIG_OK or not ser_active,
        "u_asi": not ec_flags & EcFlag.APF,
        "asi_active": bool(ec_flags & EcFlag.NORMAL_OPERATION_ACTIVE),
        "prg_enable": bool(ec_flags & EcFlag.AUTO_ADDRESS_AVAILABLE),
        "prj_mode": bool(ec_flags & EcFlag.CONFIGURATION_ACTIVE),
    }


def led_text(lit: dict[str, bool]) -> str:
    """``power, config err, U AS-i on; ser active off`` (in the panel's order)."""
    on = [label for name, label in LEDS.items() if lit.get(name)]
    off = [label for name, label in LEDS.items() if not lit.get(name)]
    parts = [f"{', '.join(on)} on"] if on else []
    parts += [f"{', '.join(off)} off"] if off else []
    return "; ".join(parts)


def display_code(
    phase: str, configuration_mode: bool, lps: int, lds: int, pcd: Sequence[int],
    cdi: Sequence[int], turn: int = 0,
) -> int | None:
    """The display for a master state (None: blank), as far as the state alone tells it.

    ``phase`` is "offline", "detection", "activation" or "normal"; ``lps``/``lds`` are slave
    bit lists (slave n = bit n). Configuration mode shows the detected slaves in turn
    (``turn`` picks which: the gateway shows two a second); protected mode shows a wrongly
    configured address, else nothing. Which one is the gateway's own knowledge (the one
    found first, line 304); from a state alone it is the lowest.
    """
    if phase in ("offline", "detection", "activation"):
        return {"offline": OFFLINE, "detection": DETECTION, "activation": ACTIVATION}[phase]
    if configuration_mode:
        detected = [a for a in range(SLAVES) if lds >> a & 1]
        return detected[turn % len(detected)] if detected else None
    wrong = misconfigured(lps, lds, pcd, cdi)
    return wrong[0] if wrong else None


def misconfigured(lps: int, lds: int, pcd: Sequence[int], cdi: Sequence[int]) -> list[int]:
    """The addresses 1..31 with a configuration error ("Fehlbelegung", line 300: a slave
    detected or projected that cannot be activated), ascending."""
    wrong = []
    for a in range(1, SLAVES):
        projected, present = lps >> a & 1, lds >> a & 1
        if projected != present or (projected and pcd[a] != cdi[a]):
            wrong.append(a)
    return wrong


def display_text(code: int | None) -> str:
    """What a display code means in the table, in words."""
    if code is None:
        return "blank"
    if code < SLAVES:
        return f"slave {code}"
    return DISPLAY_TEXT.get(code, f"status {code}")


def serial_setting_text(code: int) -> str:
    """An interface code of 5.6 (lines 388-404) in words: ``9600 baud, no parity, 1 stop
    bit``."""
    baud = BAUD_RATES[code // 10 - 1]
    parity, stopbits = FRAMINGS[code % 10]
    name = {"N": "no parity", "O": "odd parity", "E": "even parity"}[parity]
    return f"{baud} baud, {name}, {stopbits} stop bit{'s' if stopbits > 1 else ''}"


def derived(
    phase: str, configuration_mode: bool, lps: int, lds: int, pcd: Sequence[int],
    cdi: Sequence[int], turn: int = 0,
) -> Display:
    """``display_code`` as a ``Display`` with its meaning."""
    code = display_code(phase, configuration_mode, lps, lds, pcd, cdi, turn)
    if code is not None and code < SLAVES and not configuration_mode:
        return Display(code, f"slave {code} is wrongly configured")
    return Display(code, display_text(code))
