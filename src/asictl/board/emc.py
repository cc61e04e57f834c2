"""The EMC test mode of command 130 (PC2 manual 7.3, lines 443-457).

An EMC test puts the AS-i line under interference and counts what gets lost. The manual
gives the mode's parameters (program buffer byte 0: bit 0 repetitions allowed, bit 1
answers checked, bits 3-7 the expected answer; byte 1 the request; bytes 2-5 the slaves)
and its result (the request and error counters in buffer bytes 8-11, cleared after each
report), and no more; what it leaves open is decided here and listed in docs/verify.md:

- While the mode is on, the master sends the request to each listed slave every AS-i
  cycle of normal operation *instead of* the data exchange: no data calls, so the other
  slaves switch their outputs off (their watchdog) and the IDI stands still; the control
  program runs on, its outputs reach the slaves again when the mode ends.
- The request is the five information bits of a master call, I0..I4 in bits 0-4: with I4
  clear a data call carrying output data I0..I3 (the slave answers its input data), with
  I4 set a parameter call (the slave answers as it answers a parameter).
- An answer is missing when no single slave answers at the address or the telegram is
  lost; with answers checked, an answer other than the expected bits 3-7 is an error too
  (a slave answers four bits, so an expected value with bit 7 set never matches). With
  repetitions allowed a failed request is sent once more at once, as AS-i masters do.
- Each command 130 reports and clears the counters and takes the new parameters; an
  empty slave list ends the mode, and so does a power-up.
"""

from __future__ import annotations

from dataclasses import dataclass

from asictl.board.asi import AsiBus, Slave
from asictl.platform.master import SLAVES
from asictl.platform.pc2 import EMC_CHECK, EMC_EXPECTED_SHIFT, EMC_REPETITIONS

#: Bit I4 of the request: a parameter call rather than a data call.
PARAMETER_CALL = 0x10


@dataclass
class EmcTest:
    """One EMC test: what to send to whom, and the counters since the last report."""

    repetitions: bool
    check: bool
    expected: int
    request: int
    slaves: int
    requests: int = 0
    failures: int = 0
    #: what one cycle added to the counters, for cycles the board skips as idle
    _last: tuple[int, int] = (0, 0)
    _input_version: int = -1

    @classmethod
    def from_buffer(cls, data: bytes) -> EmcTest | None:
        """The parameters from program buffer bytes 0-5; None for an empty slave list."""
        slaves = int.from_bytes(data[2:6], "little")
        if not slaves:
            return None
        return cls(
            repetitions=bool(data[0] & EMC_REPETITIONS), check=bool(data[0] & EMC_CHECK),
            expected=data[0] >> EMC_EXPECTED_SHIFT, request=data[1] & 0x1F, slaves=slaves,
        )

    def _answer(self, slave: Slave) -> int:
        if self.request & PARAMETER_CALL:
            return slave.receive_parameter(self.request & 0xF)
        slave.outputs = self.request & 0xF
        return slave.inputs

    def _failed(self, found: list[Slave]) -> bool:
        """One request to the slaves ``found`` at an address: did it fail?"""
        if len(found) != 1:
            return True  # nobody, or several at once: no valid answer
        slave = found[0]
        if slave.lost_telegrams:
            slave.lost_telegrams -= 1
            return True
        answer = self._answer(slave)
        return self.check and answer != self.expected

    def cycle(self, bus: AsiBus) -> None:
        """One AS-i cycle of the test: the request to every listed slave."""
        requests = failures = 0
        for address in range(SLAVES):
            if not self.slaves >> address & 1:
                continue
            found = bus.at(address)
            for _ in range(2 if self.repetitions else 1):
                requests += 1
                if not self._failed(found):
                    break
                failures += 1
        self._last = (requests, failures)
        self._input_version = bus.input_version
        self.requests += requests
        self.failures += failures

    def steady(self, bus: AsiBus) -> bool:
        """Would the next cycle add what the last one did? (The board then skips cycles.)"""
        return self._input_version == bus.input_version and not any(
            slave.lost_telegrams for slave in bus if self.slaves >> slave.address & 1
        )

    def repeat(self, cycles: int) -> None:
        """``cycles`` more cycles like the last one (skipped by the board as idle)."""
        self.requests += cycles * self._last[0]
        self.failures += cycles * self._last[1]

    def report(self) -> bytes:
        """Program buffer bytes 8-11, and the counters cleared."""
        counts = b"".join(min(n, 0xFFFF).to_bytes(2, "little")
                          for n in (self.requests, self.failures))
        self.requests = self.failures = 0
        return counts
