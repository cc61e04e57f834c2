"""Download and upload: moving a program image between the host and the master.

The procedures are written against ``Transport``, the handful of operations ACF's
download needs, so the same steps (and their interruption safety) serve every way of
reaching a master; ``Pc2Transport`` implements it with the PC2's DPRAM commands.

Interruption safety (docs/host.md): the first write of a download destroys the magic of
the image in the EEPROM, the body follows, and the block holding the header comes last.
Until that last block is stored the EEPROM holds no image the firmware accepts, so a
reset after an interruption anywhere finds no program rather than half of one (the
previous program keeps running from RAM until then).
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping
from enum import Enum
from typing import Protocol

from asictl.errors import ExitCode, UserError
from asictl.host.transports.driver import Pc2Driver
from asictl.host.transports.jobs import JobError, JobStatus
from asictl.image.eeprom import (
    HEADER_SIZE,
    MAGIC,
    Configuration,
    ImageError,
    ProgramImage,
    image_length,
)
from asictl.platform.master import EEPROM_SIZE, ControlFlag
from asictl.platform.pc2 import (
    CONTROL_FLAGS,
    ENTRY_TABLE_ADDRESS,
    ENTRY_TABLE_SIZE,
    LPS,
    PCD,
    PI,
    PP,
    PROGRAM_BUFFER,
    PROGRAM_BUFFER_SIZE,
    Command,
)
from asictl.runtime.firmware import FIRMWARE_BLOCKS

#: What the first write of a download puts over the magic.
_NO_MAGIC = bytes(len(MAGIC))
#: Flags the host may write with command 50; the others read back but are the master's.
WRITABLE_FLAGS = ~(ControlFlag.CONTROL_ACTIVE | ControlFlag.RESET) & 0xFF

Progress = Callable[[int], None]


class StartMode(Enum):
    """ACF's /s+, /s- and /s0: what the start flag is after a download."""

    START = "start"
    STOP = "stop"
    KEEP = "keep"


class Transport(Protocol):
    """The master operations a download, an upload and start/stop are made of."""

    #: the most bytes one EEPROM write or read moves
    block_size: int

    def entry_points(self) -> dict[str, int]: ...

    def write_configuration(self, configuration: Configuration) -> None: ...

    def write_eeprom(self, address: int, data: bytes) -> None: ...

    def read_eeprom(self, address: int, size: int) -> bytes: ...

    def control_flags(self) -> int: ...

    def write_control_flags(self, flags: int) -> int: ...


class Pc2Transport:
    """``Transport`` over the PC2's DPRAM commands (manual 7.3)."""

    block_size = PROGRAM_BUFFER_SIZE

    def __init__(self, driver: Pc2Driver) -> None:
        self.driver = driver

    def entry_points(self) -> dict[str, int]:
        """The firmware's function-block table: Upload (53) from FF00h (manual 3.8)."""
        table = self.read_eeprom(ENTRY_TABLE_ADDRESS, ENTRY_TABLE_SIZE)
        addresses = struct.unpack(f"<{len(FIRMWARE_BLOCKS)}H", table)
        return dict(zip(FIRMWARE_BLOCKS, addresses, strict=True))

    def write_configuration(self, configuration: Configuration) -> None:
        """As ACF and the sample driver do: LPS and PCD in configuration mode, then PP.

        The parameters go to the slaves through the PI image, which the master compares
        with its own each cycle (the manual recommends this over command 5 when no reply
        is needed, and it works while a slave is still missing).
        """
        run = self.driver.command
        run(Command.SET_OPERATION_MODE, data=1)
        self.driver.write(LPS, configuration.lps)
        run(Command.SET_LPS)
        self.driver.write(PCD, configuration.pcd)
        run(Command.SET_PERMANENT_CONFIGURATION)
        self.driver.write(PP, configuration.pp)
        run(Command.SET_PERMANENT_PARAMETER)
        try:
            run(Command.SET_OPERATION_MODE, data=0)
        except JobError as exc:
            raise exc.during("switching to protected mode") from None
        self.driver.write(PI, configuration.pp)

    def write_eeprom(self, address: int, data: bytes) -> None:
        for offset in range(0, len(data), self.block_size):
            chunk = data[offset : offset + self.block_size]
            self.driver.write(PROGRAM_BUFFER, chunk)
            self._move(Command.DOWNLOAD, address + offset, len(chunk))

    def read_eeprom(self, address: int, size: int) -> bytes:
        out = bytearray()
        for offset in range(0, size, self.block_size):
            length = min(self.block_size, size - offset)
            self._move(Command.UPLOAD, address + offset, length)
            out += self.driver.read(PROGRAM_BUFFER, length)
        return bytes(out)

    def _move(self, command: Command, address: int, size: int) -> None:
        self.driver.command(command, data=size, address=address & 0xFF, ext=address >> 8)

    def control_flags(self) -> int:
        """Get Status (51) refreshes the flags image; then read it."""
        self.driver.command(Command.GET_STATUS)
        return self.driver.read_byte(CONTROL_FLAGS)

    def write_control_flags(self, flags: int) -> int:
        """Write AS-i Control flags (50); the flags as the master has them afterwards."""
        self.driver.write_byte(CONTROL_FLAGS, flags)
        self.driver.command(Command.WRITE_CONTROL_FLAGS)
        return self.driver.read_byte(CONTROL_FLAGS)


# --------------------------------------------------------------------------- download


def linked_for(image: ProgramImage, entry_points: Mapping[str, int]) -> None:
    """Refuse an image whose firmware calls would land elsewhere on this master.

    An image compiled here is linked against the master's own table; a .hex file or an
    uploaded [RAW] image may come from a master with other firmware.
    """
    wrong = {
        name: address
        for name, address in image.entry_points.items()
        if entry_points.get(name) != address
    }
    if wrong:
        details = ", ".join(
            f"{FIRMWARE_BLOCKS[name].name} at {address:04X}h (this master: "
            f"{entry_points[name]:04X}h)" if name in entry_points else name
            for name, address in sorted(wrong.items())
        )
        raise UserError(
            f"the image was linked for other firmware: {details}; compile it from source "
            "for this master",
            ExitCode.FAILED,
        )


def download_steps(image_size: int, block_size: int) -> int:
    """The progress steps of a download: the magic, each block written, each read back."""
    return 1 + 2 * -(-image_size // block_size)


def download(
    transport: Transport, image: ProgramImage, *, start: StartMode = StartMode.KEEP,
    progress: Progress | None = None,
) -> int:
    """Store ``image`` in the master and reload it; the control flags afterwards.

    Steps: configuration (LPS, PCD, PP, PI), the magic destroyed, the blocks after the
    first, the first block (with the header), all read back and compared, then the flags
    with the reset bit so the master copies the new program from the EEPROM to RAM.
    """
    data = image.to_bytes()
    step = transport.block_size
    advance = progress or (lambda n: None)
    try:
        transport.write_configuration(image.configuration)
    except JobError as exc:
        raise exc.during("writing the [SETUP] configuration") from None
    transport.write_eeprom(0, _NO_MAGIC)
    advance(1)
    for address in range(step, len(data), step):
        transport.write_eeprom(address, data[address : address + step])
        advance(1)
    transport.write_eeprom(0, data[:step])
    advance(1)
    stored = b""
    for address in range(0, len(data), step):
        stored += transport.read_eeprom(address, min(step, len(data) - address))
        advance(1)
    if stored != data:
        transport.write_eeprom(0, _NO_MAGIC)
        first = next(i for i, (a, b) in enumerate(zip(stored, data, strict=True)) if a != b)
        raise JobError(
            JobStatus.EEPROM_ERROR,
            f"the EEPROM does not hold what was written (first difference at {first:04X}h); "
            "the image there was made invalid",
        )
    return _load(transport, _start_flag(transport, start) | image.flags)


def _start_flag(transport: Transport, start: StartMode) -> int:
    if start is StartMode.START:
        return ControlFlag.START
    if start is StartMode.STOP:
        return 0
    return transport.control_flags() & ControlFlag.START


# --------------------------------------------------------------------------- upload


def head_size(transport: Transport) -> int:
    """How many bytes ``upload_head`` reads: at least the whole header, however small the
    transport's blocks (16 on a gateway), and a whole block if it is larger."""
    return max(HEADER_SIZE, transport.block_size)


def upload_head(transport: Transport) -> bytes:
    """The EEPROM's first ``head_size`` bytes."""
    return transport.read_eeprom(0, head_size(transport))


def upload(transport: Transport, head: bytes | None = None) -> ProgramImage:
    """Read the image from the EEPROM and check it (magic, length, CRC, structure);
    ``head`` is what ``upload_head`` read, if the caller has looked at it already."""
    if head is None:
        head = upload_head(transport)
    length = image_length(head)
    if not HEADER_SIZE <= length <= EEPROM_SIZE:
        erased = not head.strip(b"\xff") or not head.strip(b"\x00")
        raise JobError(
            JobStatus.EEPROM_ERROR,
            "the master's EEPROM holds no program image"
            + (f" (its header gives a length of {length} bytes)" if length else "")
            + ("" if length or erased else (
                f" written by asictl (it starts with {head[:4].hex(' ')}): asictl reads only "
                "the images it wrote itself, not those of other tools such as the vendor's"
            )),
        )
    data = head[:length] + transport.read_eeprom(len(head), max(0, length - len(head)))
    try:
        return ProgramImage.from_bytes(data)
    except ImageError as exc:
        raise JobError(
            JobStatus.EEPROM_ERROR, f"the master's program image is invalid: {exc}"
        ) from None


# --------------------------------------------------------------------------- start/stop


def set_start(transport: Transport, *, start: bool) -> int:
    """Set or clear the start flag, keeping the other flags: ACF's /s+ and /s-."""
    flags = transport.control_flags() & WRITABLE_FLAGS & ~ControlFlag.START
    return transport.write_control_flags(flags | (ControlFlag.START if start else 0))


def reset(transport: Transport) -> int:
    """The reset bit: reload the program from the EEPROM and clear its flags."""
    return _load(transport, transport.control_flags() & WRITABLE_FLAGS)


def _load(transport: Transport, flags: int) -> int:
    """Write ``flags`` with the reset bit; the master refuses if it finds no valid program."""
    try:
        return transport.write_control_flags(flags | ControlFlag.RESET)
    except JobError as exc:
        if exc.status is not JobStatus.REFUSED:
            raise
        raise JobError(
            JobStatus.EEPROM_ERROR,
            "the master found no valid program in its EEPROM to load (reset refused)",
        ) from None

