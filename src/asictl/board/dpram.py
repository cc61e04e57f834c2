"""The PC2's dual-port RAM: 1 KB the host reaches through the port and the master owns.

The same bytes are the 8051's XDATA 0000h-03FFh, so the control program reads and writes
the flag bytes, the communication memory and the images where the host does, with no
copying. What the DPRAM adds to plain storage is bookkeeping for the board's speed: a
change to bytes the program may read "stirs" it (a program cycle that changed nothing
before may change something now), and every address knows what a host write to it means
for the master.
"""

from __future__ import annotations

from asictl.mcs51.bus import Bus
from asictl.platform import pc2 as d
from asictl.platform.pc2 import InterruptSource

# What a host write to a DPRAM byte means for the master (plain ints: the host writes
# byte by byte, a download 16 KB of them).
#: stored; the master reads it at the next AS-i cycle if it reads such bytes at all
PLAIN = 0
#: the command byte: a code other than ACK/NAK asks the master to run a command
COMMAND = 1
#: a byte the master writes cyclically: the host's value is overwritten next cycle
MASTER_OWNED = 2


def _write_kinds() -> bytes:
    kinds = bytearray([PLAIN]) * d.DPRAM_SIZE
    for start, size in (
        (d.INSTALLED_SOFTWARE, d.INSTALLED_SOFTWARE_SIZE),
        (d.IDI, d.IMAGE_SIZE),
        (d.EC_FLAGS, 1),
        (d.LAS, d.LIST_SIZE),
        (d.LDS, d.LIST_SIZE),
        (d.CDI, d.CONFIG_SIZE),
    ):
        kinds[start : start + size] = bytes([MASTER_OWNED]) * size
    kinds[d.COMMAND] = COMMAND
    return bytes(kinds)


#: One of PLAIN, COMMAND, MASTER_OWNED per address.
_KINDS = _write_kinds()


class Dpram:
    """The DPRAM with its XDATA bus, its change note and its interrupt bytes."""

    def __init__(self) -> None:
        #: the 8051's XDATA bus the control program runs on; the DPRAM is its first 1 KB
        self.xdata = Bus()
        #: the bytes themselves (all of XDATA): for reading, and for the master's writes
        #: that the program need not notice
        self.ram = self.xdata.ram
        #: something the program may read changed since its last cycle; the board clears
        #: it when it runs a program cycle
        self.stirred = True

    def image(self, address: int, size: int) -> bytes:
        return bytes(self.ram[address : address + size])

    def put(self, address: int, data: bytes | bytearray) -> None:
        """Write master data; a change is news for the running program."""
        end = address + len(data)
        if self.ram[address:end] != data:
            self.ram[address:end] = data
            self.stirred = True

    def host_write(self, address: int, value: int) -> int:
        """A byte through the data register; what it means for the master (PLAIN...)."""
        self.ram[address] = value
        self.stirred = True
        return _KINDS[address]

    def interrupt(self, source: InterruptSource) -> None:
        """Note an event in 1FFh if the host enabled it in 1FEh and it is not pending."""
        ram = self.ram
        if ram[d.INTERRUPT_ENABLE] & source and not ram[d.INTERRUPT_EVENT] & source:
            ram[d.INTERRUPT_EVENT] |= source
            self.stirred = True

    @property
    def interrupt_request(self) -> bool:
        """The ISA interrupt line: an enabled source has an event pending."""
        return bool(self.ram[d.INTERRUPT_ENABLE] & self.ram[d.INTERRUPT_EVENT])

    def snapshot(self) -> bytes:
        """The whole DPRAM, as the host would read it."""
        return bytes(self.ram[: d.DPRAM_SIZE])
