"""``asictl reset --hardware``: the PC2's power-up reset from the host, AsiPc2Reset.

The PAGE register's bit 4 holds the board in reset, "min. 200ms" (PC2 manual 7.2, line
229); AsiPc2Reset "performs a power-up reset for the AS-i PC2 board" (9.3, lines
755-758). So the bit is held ``RESET_HOLD_MS`` on the port's own clock, then released; the
board then writes its DPRAM anew (line 235) and starts up. The host waits for the
manual's board check to find it again (10.3.3: its name and version ID are back) and for
the start-up to end (normal operation, or a phase it stays in: no slave answers, no AS-i
power), then reads what the board came up with. Everything volatile is gone: the actual
parameters, the flags, the communication memory; the program is copied from the EEPROM
again, as at power-on.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from asictl.host.search import FOUND, check_board
from asictl.host.transports.driver import Pc2Driver, PortIO
from asictl.host.transports.jobs import JobError, JobStatus
from asictl.platform.pc2 import (
    EC_FLAGS,
    MASTER_NAME,
    MASTER_NAME_SIZE,
    PAGE_RESET_BIT,
    PORT_PAGE,
    VERSION_ID,
    VERSION_ID_SIZE,
    EcFlag,
)

#: "min. 200ms" (line 229).
RESET_HOLD_MS = 200.0
#: How long the host waits for the board to be found again, and for its start-up.
POWER_UP_TIMEOUT_MS = 2000.0
START_UP_TIMEOUT_MS = 1000.0
POLL_MS = 10.0


@dataclass(frozen=True)
class PowerUp:
    """What the board came up with after the reset."""

    held_ms: float
    #: from the release of the bit until the board check found the board again
    found_ms: float
    #: from then until normal operation, None if the start-up did not get there
    started_ms: float | None
    name: str
    version_id: str
    ec_flags: int

    def report(self) -> str:
        ec = self.ec_flags
        if self.started_ms is not None:
            phase = f"normal operation {self.started_ms:g} ms later"
        elif ec & EcFlag.OFFLINE_READY:
            phase = "still offline (no AS-i power?)"
        else:
            phase = "still in the detection phase (no slave answers)"
        mode = "configuration" if ec & EcFlag.CONFIGURATION_ACTIVE else "protected"
        return (
            f"hardware reset: PAGE bit 4 held {self.held_ms:g} ms; the board powered up as "
            f"{self.name} (version {self.version_id}), found again after {self.found_ms:g} "
            f"ms: {phase}, {mode} mode"
        )


def _flush(port: PortIO) -> None:
    """A port that batches its writes (a live board's) sends them now: the reset bit must
    reach the board before the hold is timed."""
    flush = getattr(port, "flush", None)
    if callable(flush):
        flush()


def _text(raw: bytes) -> str:
    return " ".join(p.decode("latin-1").strip() for p in raw.split(b"\0") if p.strip())


def hardware_reset(
    driver: Pc2Driver, wait: Callable[[float], None], hold_ms: float = RESET_HOLD_MS
) -> PowerUp:
    """Hold the reset bit ``hold_ms`` (``wait`` lets that much time pass on the board's
    clock), release it, and wait for the power-up; ``JobError`` if the board is not
    found again within ``POWER_UP_TIMEOUT_MS``."""
    port = driver.port
    port.write(PORT_PAGE, PAGE_RESET_BIT)
    _flush(port)
    wait(hold_ms)
    port.write(PORT_PAGE, 0)
    _flush(port)
    found = 0.0
    while check_board(port) != FOUND:
        if found >= POWER_UP_TIMEOUT_MS:
            raise JobError(
                JobStatus.INTERFACE_ERROR,
                f"hardware reset: the board was not found again within "
                f"{POWER_UP_TIMEOUT_MS:g} ms (no AS-i PC2 name and version ID in its DPRAM)",
            )
        wait(POLL_MS)
        found += POLL_MS
    started: float | None = 0.0
    while not driver.read_byte(EC_FLAGS) & EcFlag.NORMAL_OPERATION_ACTIVE:
        if started is None or started >= START_UP_TIMEOUT_MS:
            started = None
            break
        wait(POLL_MS)
        started += POLL_MS
    return PowerUp(
        held_ms=hold_ms, found_ms=found, started_ms=started,
        name=_text(driver.read(MASTER_NAME, MASTER_NAME_SIZE)),
        version_id=_text(driver.read(VERSION_ID, VERSION_ID_SIZE)),
        ec_flags=driver.read_byte(EC_FLAGS),
    )
