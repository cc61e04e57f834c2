"""The master's state as the host sees it: what the master writes into the DPRAM.

The master keeps its own state (execution control, AS-i Control) and mirrors it into
the DPRAM's images (manual 7.3): the lists it writes cyclically (ec-flags, IDI, LAS,
LDS, CDI and the installed-software string), the settings it rewrites when it changes
them (LPS, PCD, PP, PI, LOS, hi-flags), the AS-i Control flags and cycle times on
request, and this board's status bytes 305h-307h. Writing only what changed is what
lets a quiet board skip cycles: every image written here goes through ``Dpram.put``,
which tells the running program only about real changes.
"""

from __future__ import annotations

import math

from asictl.board.control import AsiControl
from asictl.board.dpram import Dpram
from asictl.board.execution import ExecutionControl
from asictl.platform import pc2 as d
from asictl.platform.pc2 import (
    EMULATION_MARK,
    ControlState,
    HiFlag,
    InterruptSource,
    ProgramStatus,
    StopReason,
    pack_nibbles,
)

MASTER_NAME = b"AS-i PC2 Master / AS-i Control".ljust(32, b"\0")
MASTER_VERSION = EMULATION_MARK.encode("ascii").ljust(16, b"\0")
#: The firmware version ID at 0F0h, also what the GetId block returns: eight ASCII digits,
#: which the manual's own board check CheckAsiPc2 (10.3.3) requires 64 bytes after the
#: name. The real firmware's number is unknown; this one is the emulation's (2.00).
VERSION_ID = b"00000200"

#: The master's capabilities, bytes 1-7 of the installed-software string (10.2.5): bus-capable
#: (B), AS-i error counters (F), the EMC test mode of command 130 (E, board/emc.py),
#: advanced diagnostics (D), offline phase on configuration error (C).
CAPABILITIES = "BFEDC.."

#: What the installed-software letters and the status bytes 305h-307h are made of.
_Status = tuple[bool, bool, bool, bool, bool, ProgramStatus, StopReason, ControlState]


class MasterImages:
    """Writes the master's state into the DPRAM, each image when it changed."""

    def __init__(self, dpram: Dpram, execution: ExecutionControl, control: AsiControl) -> None:
        self._dpram = dpram
        self._ec = execution
        self._control = control
        self._lists_generation = -1
        self._settings_generation = -1
        self._status: _Status | None = None

    def update(self) -> None:
        """After the execution control's step: the lists and settings that changed."""
        ec = self._ec
        if ec.generation != self._lists_generation:
            self.write_lists()
        if ec.settings_generation != self._settings_generation:
            self.write_settings()

    def update_settings(self) -> None:
        """After a program cycle: DataEx/AutoAddr/SetPP before the host's images are read."""
        if self._ec.settings_generation != self._settings_generation:
            self.write_settings()

    def host_overwrote_lists(self) -> None:
        """The host wrote bytes the master writes cyclically: they are written again."""
        self._lists_generation = -1

    def write_identity(self) -> None:
        self._dpram.put(d.MASTER_NAME, MASTER_NAME + MASTER_VERSION)
        self._dpram.put(d.VERSION_ID, VERSION_ID)

    def write_config_ok_delay(self) -> None:
        self._dpram.put(d.CONFIG_OK_DELAY, bytes([self._ec.config_ok_delay]))

    def write_lists(self) -> None:
        """What the master writes cyclically: ec-flags, IDI, LAS, LDS, CDI."""
        ec, dpram = self._ec, self._dpram
        self._lists_generation = ec.generation
        if (dpram.ram[d.EC_FLAGS] ^ ec.ec_flags) & d.EcFlag.CONFIG_OK:
            dpram.interrupt(InterruptSource.CONFIG_OK_CHANGE)
        dpram.put(d.EC_FLAGS, bytes([ec.ec_flags]))
        dpram.put(d.IDI, ec.idi)
        dpram.put(d.LAS, ec.las.to_bytes(4, "little"))
        dpram.put(d.LDS, ec.lds.to_bytes(4, "little"))
        dpram.put(d.CDI, ec.cdi)
        self._status = None
        self.write_status()

    def write_settings(self) -> None:
        """The images the master rewrites when it changes them: LPS, PCD, PP, PI, LOS, hi."""
        ec, dpram = self._ec, self._dpram
        self._settings_generation = ec.settings_generation
        dpram.put(d.LPS, ec.lps.to_bytes(4, "little"))
        dpram.put(d.PCD, ec.pcd)
        dpram.put(d.PP, pack_nibbles(ec.pp))
        dpram.put(d.PI, pack_nibbles(ec.pi))
        dpram.put(d.LOS, ec.los.to_bytes(4, "little"))
        hi = (
            (0 if ec.data_exchange_active else HiFlag.DATA_EXCHANGE_OFF)
            | (HiFlag.OFFLINE if ec.offline else 0)
            | (0 if ec.auto_address_enable else HiFlag.AUTO_ADDRESS_OFF)
        )
        dpram.put(d.HI_FLAGS, bytes([hi]))
        self._status = None
        self.write_status()

    def write_status(self) -> None:
        """The installed-software letters and this board's status bytes 305h-307h."""
        control, ec, ram = self._control, self._ec, self._dpram.ram
        status: _Status = (
            control.running, ec.data_exchange_active, ec.offline, ec.auto_address_enable,
            bool(ram[d.WATCHDOG_ENABLE]), control.program_status, control.reason, control.state,
        )
        if status == self._status:
            return
        self._status = status
        letters = (
            "C" if control.running else "c",
            CAPABILITIES,
            "D" if ec.data_exchange_active else "d",
            "O" if ec.offline else "o",
            "A" if ec.auto_address_enable else "a",
            "...",
            "W" if ram[d.WATCHDOG_ENABLE] else "w",
            ".",
        )
        self._dpram.put(d.INSTALLED_SOFTWARE, "".join(letters).encode("ascii"))
        self._dpram.put(
            d.PROGRAM_STATUS, bytes([control.program_status, control.reason, control.state])
        )

    def write_control_flags(self) -> None:
        """304h, on request (commands 50, 51, 128 and at power-up)."""
        self._dpram.ram[d.CONTROL_FLAGS] = self._control.flags_byte()

    def write_cycle_times(self) -> None:
        """300h-303h, on request: 10 us units, rounded up, saturating."""
        for address, us in (
            (d.CYCLE_TIME_PREVIOUS, self._control.previous_us),
            (d.CYCLE_TIME_MAXIMUM, self._control.maximum_us),
        ):
            units = min(0xFFFF, math.ceil(us / d.CYCLE_TIME_UNIT_US))
            self._dpram.put(address, units.to_bytes(2, "little"))
