"""A minimal host for the emulated PC2 board, as the manual's sample driver does it.

The tests drive the board only through its three registers, so this is the sample C
program's Page/Index/Read/Write and send_cmd, with virtual time instead of a clock.
"""

from __future__ import annotations

from collections.abc import Iterable

from asictl.board.board import Pc2Board
from asictl.build import build_image
from asictl.codegen8051.compiler import compile_program
from asictl.il.checks import check_source
from asictl.image.eeprom import ProgramImage
from asictl.platform import pc2 as d
from asictl.platform.master import ControlFlag
from asictl.source import from_string


class CommandTimeout(AssertionError):
    """The board did not answer a command within the sample driver's 200 ms."""


class Host:
    def __init__(self, board: Pc2Board) -> None:
        self.board = board

    def seek(self, address: int) -> None:
        self.board.io_write(d.PORT_PAGE, address >> 8)
        self.board.io_write(d.PORT_INDEX, address & 0xFF)

    def write(self, address: int, data: bytes | Iterable[int] | int) -> None:
        self.seek(address)
        for value in [data] if isinstance(data, int) else data:
            self.board.io_write(d.PORT_DATA, value)

    def read(self, address: int, count: int = 1) -> bytes:
        self.seek(address)
        return bytes(self.board.io_read(d.PORT_DATA) for _ in range(count))

    def byte(self, address: int) -> int:
        return self.read(address)[0]

    def command(
        self,
        code: int,
        *,
        data: int | None = None,
        address: int | None = None,
        extension: int | None = None,
    ) -> int:
        """Write the parameters and the code, poll the command byte: 00h or FFh."""
        for where, value in ((d.DATA, data), (d.ADDRESS, address), (d.ADDRESS_EXT, extension)):
            if value is not None:
                self.write(where, value)
        self.write(d.COMMAND, code)
        for _ in range(d.COMMAND_TIMEOUT_MS):
            self.board.advance(1)
            answer = self.byte(d.COMMAND)
            if answer != code:
                return answer
        raise CommandTimeout(f"command {code} not answered")

    def ok(self, code: int, **params: int) -> None:
        answer = self.command(code, **params)
        assert answer == d.ACK, f"command {code} answered {answer:02X}h"

    def download(self, data: bytes, start: int = 0) -> None:
        for offset in range(0, len(data), d.PROGRAM_BUFFER_SIZE):
            block = data[offset : offset + d.PROGRAM_BUFFER_SIZE]
            self.write(d.PROGRAM_BUFFER, block)
            at = start + offset
            self.ok(d.Command.DOWNLOAD, data=len(block), address=at & 0xFF, extension=at >> 8)

    def upload(self, start: int, size: int) -> bytes:
        out = bytearray()
        for offset in range(0, size, d.PROGRAM_BUFFER_SIZE):
            count = min(d.PROGRAM_BUFFER_SIZE, size - offset)
            at = start + offset
            self.ok(d.Command.UPLOAD, data=count, address=at & 0xFF, extension=at >> 8)
            out += self.read(d.PROGRAM_BUFFER, count)
        return bytes(out)

    def control_flags(self, flags: int) -> int:
        """Command 50 with these flags; the answer."""
        self.write(d.CONTROL_FLAGS, flags)
        return self.command(d.Command.WRITE_CONTROL_FLAGS)

    def project(self, image: ProgramImage) -> None:
        """What a download does first: the image's LPS, PCD and PP, in configuration mode."""
        configuration = image.configuration
        self.ok(d.Command.SET_OPERATION_MODE, data=1)
        self.write(d.LPS, configuration.lps)
        self.ok(d.Command.SET_LPS)
        self.write(d.PCD, configuration.pcd)
        self.ok(d.Command.SET_PERMANENT_CONFIGURATION)
        self.write(d.PP, configuration.pp)
        self.ok(d.Command.SET_PERMANENT_PARAMETER)
        self.ok(d.Command.SET_OPERATION_MODE, data=0)

    def install(self, image: ProgramImage, *, start: bool = True) -> int:
        """Project, download, reset (and start); the answer to command 50."""
        self.project(image)
        self.download(image.to_bytes())
        return self.control_flags(image.flags | ControlFlag.RESET | (1 if start else 0))

    # views
    def ec_flags(self) -> d.EcFlag:
        return d.EcFlag(self.byte(d.EC_FLAGS))

    def slaves(self, where: int) -> set[int]:
        return d.slave_list(self.read(where, d.LIST_SIZE))

    def outputs(self) -> bytes:
        """The ODI as values per slave (un-inverted)."""
        return d.nibbles(bytes(~b & 0xFF for b in self.read(d.ODI, d.IMAGE_SIZE)))

    def inputs(self) -> bytes:
        return d.nibbles(self.read(d.IDI, d.IMAGE_SIZE))

    def set_outputs(self, values: dict[int, int]) -> None:
        current = bytearray(self.outputs())
        for address, value in values.items():
            current[address] = value
        self.write(d.ODI, bytes(~b & 0xFF for b in d.pack_nibbles(current)))

    def letters(self) -> str:
        return self.read(d.INSTALLED_SOFTWARE, d.INSTALLED_SOFTWARE_SIZE).decode("ascii")


def compile_image(text: str) -> ProgramImage:
    result = check_source(from_string("test.asi", text))
    assert not result.has_errors, result.diagnostics
    return build_image(compile_program(result.program))
