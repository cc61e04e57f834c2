"""The 8051's two 64 KB external address spaces: code memory and XDATA.

XDATA is a bus: plain RAM by default, with devices mapped onto address ranges. The
emulated AS-i master puts its dual-port RAM there, so the bus keeps one callback slot
per address. The emulator's hot path is then ``handler = readers[addr]`` followed by
``ram[addr]`` when the slot is empty: two list/bytearray indexings and no call, whatever
is mapped elsewhere.

Code memory is separate (Harvard architecture: no 8051 instruction writes it), so the
only writes come from the host. ``CodeMemory`` reports them, because the emulator
caches translations of the code and must drop them when the bytes underneath change.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import SupportsIndex, cast, overload

#: Size of each of the 8051's external address spaces.
SPACE = 0x10000

#: A device read: called with the absolute bus address, returns the byte there.
ReadHandler = Callable[[int], int]
#: A device write: called with the absolute bus address and the byte written.
WriteHandler = Callable[[int, int], None]


class CodeMemory(bytearray):
    """64 KB of program memory that tells its owner when it is written.

    Reads are plain ``bytearray`` indexing (inherited, so as fast as a bytearray).
    Writes through ``code[i] = v``, slice assignment or ``load`` call ``on_write``, which
    the emulator uses to invalidate translated code.
    """

    def __init__(self) -> None:
        super().__init__(SPACE)
        self.on_write: Callable[[], None] | None = None

    @overload
    def __setitem__(self, index: SupportsIndex, value: SupportsIndex, /) -> None: ...
    @overload
    def __setitem__(self, index: slice, value: Iterable[SupportsIndex] | bytes, /) -> None: ...
    def __setitem__(
        self,
        index: SupportsIndex | slice,
        value: SupportsIndex | Iterable[SupportsIndex] | bytes,
        /,
    ) -> None:
        if isinstance(index, slice):
            data = bytes(value)
            if len(range(*index.indices(SPACE))) != len(data):
                raise ValueError("code memory is fixed at 64 KB; assign slices of equal length")
            super().__setitem__(index, data)
        else:
            # The overloads pair an index with one byte, which mypy does not carry over here.
            super().__setitem__(index, cast(SupportsIndex, value))
        if self.on_write is not None:
            self.on_write()

    def load(self, address: int, data: bytes | Iterable[int]) -> None:
        """Copy ``data`` to ``address``, wrapping at 64 KB as the program counter does."""
        data = bytes(data)
        end = address + len(data)
        if end <= SPACE:
            self[address:end] = data
        else:
            split = SPACE - address
            self[address:] = data[:split]
            self[: end - SPACE] = data[split:]


@dataclass(frozen=True, slots=True)
class Mapping:
    """One device's window on the bus, inclusive of both ends."""

    start: int
    end: int
    name: str
    read: ReadHandler | None
    write: WriteHandler | None

    def __str__(self) -> str:
        return f"{self.name} at {self.start:04X}h-{self.end:04X}h"


class Bus:
    """XDATA: 64 KB of RAM with devices mapped over address ranges.

    ``ram`` backs every address no device claims, and also the direction a device leaves
    to RAM (a device mapped with only ``write`` sees every write while reads come from
    ``ram``, which suits a watched mailbox). ``readers`` and ``writers`` hold the handler
    for each address or ``None``; they are exposed so the emulator can index them directly.
    """

    def __init__(self) -> None:
        self.ram = bytearray(SPACE)
        self.readers: list[ReadHandler | None] = [None] * SPACE
        self.writers: list[WriteHandler | None] = [None] * SPACE
        self._mappings: list[Mapping] = []
        #: no device is mapped: every address is RAM (code may then use ``ram`` directly);
        #: a plain attribute, kept by ``map`` and ``unmap``, since every program cycle asks
        self.plain = True

    @property
    def mappings(self) -> tuple[Mapping, ...]:
        """The mapped devices, in address order."""
        return tuple(sorted(self._mappings, key=lambda m: m.start))

    def map(
        self,
        start: int,
        end: int,
        *,
        read: ReadHandler | None = None,
        write: WriteHandler | None = None,
        name: str = "device",
    ) -> Mapping:
        """Map a device over ``start..end`` (inclusive); refuses to overlap another device.

        Overlaps are refused rather than layered because a silently shadowed device is a
        wiring bug that would otherwise surface as wrong data far from its cause.
        """
        if not 0 <= start <= end < SPACE:
            raise ValueError(
                f"{name}: address range {start:#06x}-{end:#06x} is not within 0000h-FFFFh"
            )
        if read is None and write is None:
            raise ValueError(f"{name}: a device needs a read or a write handler")
        for other in self._mappings:
            if start <= other.end and other.start <= end:
                raise ValueError(
                    f"{name} at {start:04X}h-{end:04X}h overlaps {other}; unmap it first"
                )
        mapping = Mapping(start, end, name, read, write)
        self._mappings.append(mapping)
        self.plain = False
        span = end - start + 1
        self.readers[start : end + 1] = [read] * span
        self.writers[start : end + 1] = [write] * span
        return mapping

    def unmap(self, mapping: Mapping) -> None:
        """Remove a device; its addresses become plain RAM again."""
        self._mappings.remove(mapping)
        self.plain = not self._mappings
        span = mapping.end - mapping.start + 1
        self.readers[mapping.start : mapping.end + 1] = [None] * span
        self.writers[mapping.start : mapping.end + 1] = [None] * span

    def read(self, address: int) -> int:
        """The byte a MOVX read of ``address`` sees."""
        handler = self.readers[address]
        return self.ram[address] if handler is None else handler(address) & 0xFF

    def write(self, address: int, value: int) -> None:
        """Store a byte as a MOVX write to ``address`` does."""
        handler = self.writers[address]
        if handler is None:
            self.ram[address] = value
        else:
            handler(address, value)
