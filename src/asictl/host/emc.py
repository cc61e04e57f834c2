"""``asictl emc``: command 130, the EMC test mode (PC2 manual 7.3, lines 443-457).

A test is three steps of the same command: 130 with the parameters starts it (and reports
what a test before it counted), the line is disturbed for a while, 130 with an empty slave
list ends it and reports the requests sent and the answers missing or wrong since. A
master without the option refuses 130; its installed-software byte 3 then says 'e'
(10.2.5), and the refusal says so. The emulated master's model of the mode is
board/emc.py.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from asictl.host.transports.driver import Pc2Driver
from asictl.host.transports.jobs import JobError, JobStatus
from asictl.platform.pc2 import (
    EMC_COUNTERS,
    INSTALLED_SOFTWARE,
    PROGRAM_BUFFER,
    Command,
    emc_parameters,
)

#: How often a running test is read: its 16-bit counters hold some 20 s of AS-i cycles.
REPORT_EVERY_S = 5.0


@dataclass(frozen=True)
class EmcCounts:
    """What one 130 reported: the test's requests and failed answers since the last."""

    requests: int
    failures: int

    @property
    def failed_percent(self) -> float:
        return 100.0 * self.failures / self.requests if self.requests else 0.0


def emc_command(driver: Pc2Driver, parameters: bytes) -> EmcCounts:
    """One command 130 with ``parameters`` (program buffer bytes 0-5)."""
    driver.write(PROGRAM_BUFFER, parameters)
    try:
        driver.command(Command.EMC_TEST_MODE)
    except JobError as exc:
        if exc.status is not JobStatus.REFUSED:
            raise
        letter = driver.read(INSTALLED_SOFTWARE + 3, 1).decode("latin-1")
        raise JobError(exc.status, f"{exc.message}: the master has no EMC test mode " + (
            "(installed software byte 3 is 'e')" if letter == "e" else
            f"(installed software byte 3 is '{letter}')"
        )) from None
    counts = driver.read(PROGRAM_BUFFER + EMC_COUNTERS, 4)
    return EmcCounts(int.from_bytes(counts[:2], "little"), int.from_bytes(counts[2:], "little"))


def emc_test(
    driver: Pc2Driver, slaves: list[int], request: int, *, expected: int | None,
    repetitions: bool, seconds: float, wait: Callable[[float], None], keep: bool = False,
) -> EmcCounts:
    """A test of ``seconds``: start, wait (``wait`` takes milliseconds of the board's
    time), end (or, with ``keep``, report and go on); its counts. The master's counters
    have 16 bits, so the test is read (and they are cleared) every ``REPORT_EVERY_S``."""
    parameters = emc_parameters(slaves, request, expected=expected, repetitions=repetitions)
    emc_command(driver, parameters)
    requests = failures = 0
    left = seconds
    while left > 0:
        step = min(left, REPORT_EVERY_S)
        wait(step * 1000)
        left -= step
        last = left <= 0 and not keep
        counts = emc_command(driver, emc_parameters([], 0) if last else parameters)
        requests += counts.requests
        failures += counts.failures
    return EmcCounts(requests, failures)
