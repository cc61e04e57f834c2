"""What every AS-i master with AS-i Control has, whichever way a host reaches it.

The numbers here are fixed by the AS-i specification and the manuals (PC2 manual 7.3 and
10.2.6, gateway manual register 1009, programming manual 3.1); the compiler, the image
format, the emulated board, the gateway and the host side all take them from here.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import IntFlag
from typing import ClassVar

#: AS-i addresses 0..31; 0 is a new slave, never projected.
SLAVES = 32
#: The master's EEPROM, which holds the program image and nothing else.
EEPROM_SIZE = 16 * 1024
#: A slave's parameter after power-up, and what [SETUP] projects when it gives none (3.2).
DEFAULT_PARAMETER = 0xF
#: The profile byte (PCD/CDI) of an address without a (projected) slave: I/O F, ID F.
NO_PROFILE = 0xFF

#: The master's 8051 runs at 11.0592 MHz, 12 clocks a machine cycle.
CRYSTAL_HZ = 11_059_200
MACHINE_CYCLE_US = 12 * 1_000_000 / CRYSTAL_HZ
#: The master's clock for timers and the watchdog.
TICK_MS = 10
TICK_US = TICK_MS * 1000
#: A program cycle longer than this is an endless loop: the master stops the program.
CYCLE_TIMEOUT_MS = 200
#: One AS-i transaction (master call, pauses, slave answer) and the cycle's management call.
TRANSACTION_US = 150


def asi_cycle_us(slaves: int) -> int:
    """The AS-i cycle with ``slaves`` active slaves: a transaction each, plus one call
    (300 us with one slave, 4.8 ms with 31); the emulated master's, the prover's."""
    return TRANSACTION_US * (max(slaves, 1) + 1)

#: AS-i Control II has 1024 timers and 1024 counters, 0..1023 (programming manual 2).
MAX_TC = 1023
#: map_counters: counter n (0..14) is flag bytes 96+2n (low) and 97+2n (high nibble).
COUNTER_FLAG_BASE = 96
MAPPED_COUNTERS = 15
#: Their high bytes, F97, F99 .. F125: only bits 0-3 hold the count, the upper four are
#: always 0 (whatever the program or the host writes there).
COUNTER_HIGH_FLAGS = range(COUNTER_FLAG_BASE + 1, COUNTER_FLAG_BASE + 2 * MAPPED_COUNTERS, 2)


def flag_keeps(n: int, map_counters: bool) -> int:
    """The bits of flag byte ``n`` that keep what is written to them: all eight, but only
    bits 0-3 of a mapped counter's high byte, so a program that writes it and reads it
    back in the same cycle reads what the counter holds (the compiled code, the
    interpreter and the prover all mask with this)."""
    return 0x0F if map_counters and n in COUNTER_HIGH_FLAGS else 0xFF

#: The AS-i I/O codes by their data bits D0..D3 (I input, O output, B both, T tristate).
IO_CODE_BITS = (
    "iiii", "iiio", "iiib", "iioo", "iibb", "iooo", "ibbb", "bbbb",
    "oooo", "oooi", "ooob", "ooii", "oobb", "oiii", "obbb", "tttt",
)
#: The I/O codes written as letters, by their letters (``iiio`` = 1); F, tristate, has
#: none and is written as a number.
IO_CODES = {letters: code for code, letters in enumerate(IO_CODE_BITS) if "t" not in letters}


class ControlFlag(IntFlag):
    """The AS-i Control flags byte (PC2 DPRAM 304h, gateway holding register 1009).

    ``WAIT_FOR_SET_BUTTON`` is the manual's "auto_start" bit with its inverted meaning:
    set, a stopped program waits for the set button ([OPTIONS] ``auto_start: no``).
    """

    START = 0x01
    RESET = 0x02
    IGNORE_CONFIG_ERRORS = 0x04
    WAIT_FOR_SET_BUTTON = 0x08
    MAP_COUNTERS = 0x10
    CONTROL_ACTIVE = 0x20


#: The control flags the host may set and that survive power-off.
CONTROL_FLAGS_NONVOLATILE = (
    ControlFlag.START
    | ControlFlag.IGNORE_CONFIG_ERRORS
    | ControlFlag.WAIT_FOR_SET_BUTTON
    | ControlFlag.MAP_COUNTERS
)
#: The control flags a program's [OPTIONS] decide (an image carries exactly these).
OPTION_FLAGS = (
    ControlFlag.IGNORE_CONFIG_ERRORS | ControlFlag.WAIT_FOR_SET_BUTTON | ControlFlag.MAP_COUNTERS
)


@dataclass(frozen=True)
class Options:
    """The [OPTIONS] flags, with the manual's defaults (3.1)."""

    ignore_config_errors: bool = False
    auto_start: bool = True
    map_counters: bool = False

    #: the option names, in the order the manual lists them
    NAMES: ClassVar[tuple[str, ...]] = ("ignore_config_errors", "auto_start", "map_counters")

    @classmethod
    def from_values(cls, values: Mapping[str, bool]) -> Options:
        """From option name (lower case) -> value; names not given keep their default."""
        return cls(**{name: values[name] for name in cls.NAMES if name in values})

    @classmethod
    def from_flags(cls, flags: int) -> Options:
        return cls(
            ignore_config_errors=bool(flags & ControlFlag.IGNORE_CONFIG_ERRORS),
            auto_start=not flags & ControlFlag.WAIT_FOR_SET_BUTTON,
            map_counters=bool(flags & ControlFlag.MAP_COUNTERS),
        )

    def control_flags(self) -> int:
        """The control flags these options set; start is the download's decision."""
        return int(
            (ControlFlag.IGNORE_CONFIG_ERRORS if self.ignore_config_errors else 0)
            | (0 if self.auto_start else ControlFlag.WAIT_FOR_SET_BUTTON)
            | (ControlFlag.MAP_COUNTERS if self.map_counters else 0)
        )

    def values(self) -> dict[str, bool]:
        return {name: getattr(self, name) for name in self.NAMES}
