"""Helpers for the host-side tests (imported explicitly: ``from host_helpers import ...``).

``ScriptedBoard`` is a register-level stand-in with scripted command answers, for
testing the driver and jobs apart from the emulated master. ``WiredDevPort`` puts a
board behind a plain file in place of /dev/port, so ``DevPort``'s own pread/pwrite at
base+offset is what the tests exercise; ``isa_bus`` does so for emulated boards at any
bases of an otherwise empty ISA bus. ``InterruptingPort`` raises after N accesses.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from asictl.board.board import Pc2Board
from asictl.host.transports.driver import DevPort, PortIO
from asictl.platform.pc2 import (
    COMMAND,
    DPRAM_SIZE,
    PAGE_MASK,
    PAGE_SIZE,
    PORT_DATA,
    PORT_INDEX,
    PORT_PAGE,
)


class ScriptedBoard:
    """DPRAM and the three registers; a pending command is answered on ``advance``.

    ``answers`` maps a command code to a function of the board that returns the
    acknowledge (00h, FFh, or anything else); a code without an answer is never
    acknowledged. ``delay_ms`` is how long the board takes to answer.
    """

    def __init__(
        self, answers: dict[int, Callable[[ScriptedBoard], int]] | None = None,
        delay_ms: float = 0.0,
    ) -> None:
        self.dpram = bytearray(DPRAM_SIZE)
        self.index = self.page = 0
        self.now_ms = 0.0
        self.answers = answers or {}
        self.delay_ms = delay_ms
        self._issued_at: float | None = None
        self.accesses = 0

    def io_read(self, offset: int) -> int:
        self.accesses += 1
        if offset != PORT_DATA:
            return 0xFF
        value = self.dpram[self.page << 8 | self.index]
        self._step()
        return value

    def io_write(self, offset: int, value: int) -> None:
        self.accesses += 1
        if offset == PORT_INDEX:
            self.index = value
        elif offset == PORT_PAGE:
            self.page = value & PAGE_MASK
        else:
            address = self.page << 8 | self.index
            self.dpram[address] = value
            if address == COMMAND:
                self._issued_at = self.now_ms
            self._step()

    def _step(self) -> None:
        self.index += 1
        if self.index == PAGE_SIZE:
            self.index = self.page = 0

    def advance(self, ms: float) -> None:
        self.now_ms += ms
        code = self.dpram[COMMAND]
        if self._issued_at is None or self.now_ms - self._issued_at < self.delay_ms:
            return
        answer = self.answers.get(code)
        if answer is not None:
            self.dpram[COMMAND] = answer(self)
            self._issued_at = None


class WiredDevPort(DevPort):
    """``DevPort`` on a file, with a board that plays the registers behind it.

    Before a read the board puts the register's value into the file; after a write it
    takes the byte the driver put there. The bytes travel through the file only.
    """

    def __init__(self, base: int, path: str, board: ScriptedBoard) -> None:
        super().__init__(base, path)
        self.board = board

    def read(self, offset: int) -> int:
        if offset == PORT_DATA and self.board.page << 8 | self.board.index == COMMAND:
            self.board.advance(1.0)
        os.pwrite(self._fd, bytes([self.board.io_read(offset)]), self.base + offset)
        return super().read(offset)

    def write(self, offset: int, value: int) -> None:
        super().write(offset, value)
        self.board.io_write(offset, os.pread(self._fd, 1, self.base + offset)[0])

    def now_ms(self) -> float:
        return self.board.now_ms


class Interrupted(Exception):
    """Stands for a power cut, a pulled cable or Ctrl-C at one exact port access."""


class InterruptingPort:
    """Passes ``after`` accesses through, then raises ``Interrupted`` on the next one."""

    def __init__(self, port: PortIO, after: int | None = None) -> None:
        self.port = port
        self.after = after
        self.count = 0

    def _tick(self) -> None:
        if self.after is not None and self.count >= self.after:
            raise Interrupted(f"interrupted at port access {self.count}")
        self.count += 1

    def read(self, offset: int) -> int:
        self._tick()
        return self.port.read(offset)

    def write(self, offset: int, value: int) -> None:
        self._tick()
        self.port.write(offset, value)

    def now_ms(self) -> float:
        return self.port.now_ms()


class IsaPort(DevPort):
    """``DevPort`` on a file standing for the PC's I/O space: at ``base`` either nothing
    (the file's FFh: an empty ISA address) or an emulated board, whose register values
    pass through the file."""

    def __init__(self, base: int, path: str, board: Pc2Board | None) -> None:
        super().__init__(base, path)
        self.board = board

    def read(self, offset: int) -> int:
        if self.board is not None:
            self.board.advance(0.001)  # an 8-bit ISA cycle
            os.pwrite(self._fd, bytes([self.board.io_read(offset)]), self.base + offset)
        return super().read(offset)

    def write(self, offset: int, value: int) -> None:
        super().write(offset, value)
        if self.board is not None:
            self.board.advance(0.001)
            self.board.io_write(offset, os.pread(self._fd, 1, self.base + offset)[0])


def isa_bus(path: Path, boards: dict[int, Pc2Board]) -> Callable[[int], DevPort]:
    """What stands for ``DevPort(base)``: /dev/port as the file ``path``, with ``boards``
    at their bases and nothing anywhere else."""
    path.write_bytes(b"\xff" * 0x10000)
    return lambda base: IsaPort(base, str(path), boards.get(base))
