"""The host driver of the PC2 board, written only against its three I/O registers.

Everything the host does goes through offset 0 (data), 1 (INDEX) and 2 (PAGE) of the
board's I/O base (manual 7.2), as in the manual's sample drivers: a real board through
Linux ``/dev/port`` and the emulated board through the same three registers, so the
emulated board checks the very code that drives the real one. The driver knows the
DPRAM's page wrap (after byte 255 of a page both INDEX and PAGE start again at 0) and
re-points at every page boundary; commands run as jobs (``jobs.py``).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from asictl.host.transports.jobs import Job, PortError
from asictl.platform.pc2 import (
    ACK,
    COMMAND,
    COMMAND_TIMEOUT_MS,
    DATA,
    DPRAM_SIZE,
    NAK,
    PAGE_MASK,
    PAGE_SIZE,
    PORT_DATA,
    PORT_INDEX,
    PORT_PAGE,
)

if TYPE_CHECKING:
    from asictl.board.board import Pc2Board

#: Master time one poll of the command byte costs on the emulated board.
EMULATED_POLL_MS = 1.0


class PortIO(Protocol):
    """The board's three I/O registers, and the clock command time-outs run on."""

    def read(self, offset: int) -> int: ...

    def write(self, offset: int, value: int) -> None: ...

    def now_ms(self) -> float: ...


@runtime_checkable
class BlockPortIO(PortIO, Protocol):
    """A port that can read a run of data bytes in one access (a live board's socket)."""

    def read_data(self, count: int) -> bytes: ...


class EmulatedPort:
    """The emulated board's registers; reading the command byte costs master time.

    The emulated master only runs when told to, so the host's polling is what moves its
    clock: each read of the data register while INDEX/PAGE point at the command byte
    advances the board by ``EMULATED_POLL_MS`` first. A command the board executes
    within its next millisecond is then acknowledged on the first poll, and the 200 ms
    time-out is 200 polls of master time, however fast the host runs.

    A live board served by this process (``host.live``) passes its own ``advance`` (master
    time through a debugger's hold) and ``on_command`` (run a command just written as a
    client's through the socket is run: to its acknowledge, or answered at once while a
    debugger holds the master still).
    """

    def __init__(
        self, board: Pc2Board, *, advance: Callable[[float], None] | None = None,
        on_command: Callable[[], None] | None = None,
    ) -> None:
        self.board = board
        self._advance = advance or board.advance
        self._on_command = on_command
        #: the DPRAM address the next data access goes to, followed like the board does
        self._pointer = 0

    def read(self, offset: int) -> int:
        if offset == PORT_DATA:
            if self._pointer == COMMAND:
                self._advance(EMULATED_POLL_MS)
            self._step()
        return self.board.io_read(offset)

    def write(self, offset: int, value: int) -> None:
        if offset == PORT_DATA:
            command = self._pointer == COMMAND and value not in (ACK, NAK)
            self._step()
            self.board.io_write(offset, value)
            if command and self._on_command is not None:
                self._on_command()
            return
        elif offset == PORT_INDEX:
            self._pointer = self._pointer & ~0xFF | value & 0xFF
        elif offset == PORT_PAGE:
            self._pointer = (value & PAGE_MASK) << 8 | self._pointer & 0xFF
        self.board.io_write(offset, value)

    def _step(self) -> None:
        index = (self._pointer & 0xFF) + 1
        self._pointer = self._pointer + 1 if index < PAGE_SIZE else 0

    def now_ms(self) -> float:
        return self.board.now_ms


class DevPort:
    """A real board through ``/dev/port`` (root or CAP_SYS_RAWIO): one byte per access.

    ``path`` exists for tests, which put a file and a scripted board in its place.
    """

    def __init__(self, base: int, path: str = "/dev/port") -> None:
        self.base, self.path = base, path
        try:
            self._fd = os.open(path, os.O_RDWR)
        except PermissionError:
            raise PortError(
                f"{path}: permission denied; direct port access needs root (or CAP_SYS_RAWIO)"
            ) from None
        except FileNotFoundError:
            raise PortError(f"{path}: not present; this system has no direct port access") from None
        except OSError as exc:
            raise PortError(f"{path}: cannot open: {exc.strerror or exc}") from None

    def read(self, offset: int) -> int:
        try:
            data = os.pread(self._fd, 1, self.base + offset)
        except OSError as exc:
            raise PortError(f"{self._where(offset)}: cannot read: {exc.strerror or exc}") from None
        if len(data) != 1:
            raise PortError(f"{self._where(offset)}: cannot read: end of {self.path}")
        return data[0]

    def write(self, offset: int, value: int) -> None:
        try:
            os.pwrite(self._fd, bytes([value & 0xFF]), self.base + offset)
        except OSError as exc:
            raise PortError(f"{self._where(offset)}: cannot write: {exc.strerror or exc}") from None

    def _where(self, offset: int) -> str:
        return f"{self.path} port {self.base + offset:X}h"

    def now_ms(self) -> float:
        return time.monotonic() * 1000.0

    def close(self) -> None:
        os.close(self._fd)


class Pc2Driver:
    """DPRAM blocks and commands over a ``PortIO``; the ``CommandPort`` that jobs use."""

    def __init__(self, port: PortIO) -> None:
        self.port = port
        # asked once: a check against a runtime-checkable protocol looks up each of its
        # methods, and took longer than many a read it chose the way for
        self._read_block = port.read_data if isinstance(port, BlockPortIO) else None

    def _point(self, address: int) -> None:
        self.port.write(PORT_INDEX, address & 0xFF)
        self.port.write(PORT_PAGE, address >> 8 & PAGE_MASK)

    def _chunks(self, address: int, size: int) -> Iterator[tuple[int, int]]:
        """(address, length) pieces of a block that each stay within one page."""
        if address < 0 or size < 0 or address + size > DPRAM_SIZE:
            raise ValueError(f"DPRAM block {address:X}h+{size} is outside 000h-3FFh")
        while size:
            length = min(size, PAGE_SIZE - address % PAGE_SIZE)
            yield address, length
            address, size = address + length, size - length

    def read(self, address: int, size: int) -> bytes:
        out = bytearray()
        port = self.port
        block = self._read_block
        for start, length in self._chunks(address, size):
            self._point(start)
            if block is not None:
                out += block(length)
            else:
                out += bytes([port.read(PORT_DATA) for _ in range(length)])
        return bytes(out)

    def write(self, address: int, data: bytes) -> None:
        write = self.port.write
        offset = 0
        for start, length in self._chunks(address, len(data)):
            self._point(start)
            for value in data[offset : offset + length]:
                write(PORT_DATA, value)
            offset += length

    def read_byte(self, address: int) -> int:
        return self.read(address, 1)[0]

    def write_byte(self, address: int, value: int) -> None:
        self.write(address, bytes([value]))

    # --- the CommandPort of jobs.py

    def issue(self, code: int, data: int, address: int, ext: int) -> None:
        """Parameters first, then the code: the master acts as soon as the code is there."""
        self.write(DATA, bytes([data & 0xFF, address & 0xFF, ext & 0xFF]))
        self.write_byte(COMMAND, code)

    def acknowledge(self) -> int:
        return self.read_byte(COMMAND)

    def result(self) -> int:
        return self.read_byte(DATA)

    def now_ms(self) -> float:
        return self.port.now_ms()

    def command(
        self, code: int, data: int = 0, address: int = 0, ext: int = 0,
        timeout_ms: float = COMMAND_TIMEOUT_MS,
    ) -> int:
        """Run one command to its end; the byte it leaves in ``data``. Raises ``JobError``."""
        return Job(self, code, data, address, ext, timeout_ms=timeout_ms).run()

