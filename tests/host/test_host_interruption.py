"""An interrupted download never leaves a program that starts (docs/host.md).

A download of a multi-block image is cut at every command (before it, inside its
parameters, right after the code is written, between polls), in the middle of every
block's transfer into the program buffer, and between every pair of commands. After each
cut: the previous program still runs from RAM; a reset with the start flag then finds
either no valid program or a complete one (the old one before the first EEPROM write,
the new one once its header block is stored), never a mixture; and a full download
afterwards works.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from host_helpers import Interrupted, InterruptingPort

from asictl.board.board import Pc2Board
from asictl.build import build_file
from asictl.host.transfer import Pc2Transport, StartMode, download, reset
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.host.transports.jobs import JobError, JobStatus
from asictl.image.eeprom import ProgramImage
from asictl.platform.master import ControlFlag
from asictl.platform.pc2 import Command, ProgramStatus

DEMOS = Path(__file__).resolve().parents[2] / "demos"


class RecordingDriver(Pc2Driver):
    """Notes the port access count at the start and end of every command's issue."""

    def __init__(self, port: InterruptingPort) -> None:
        super().__init__(port)
        self.counter = port
        self.issued: list[tuple[int, int, int]] = []

    def issue(self, code: int, data: int, address: int, ext: int) -> None:
        start = self.counter.count
        super().issue(code, data, address, ext)
        self.issued.append((code, start, self.counter.count))


def image_of(name: str) -> ProgramImage:
    board = Pc2Board()
    entry_points = Pc2Transport(Pc2Driver(EmulatedPort(board))).entry_points()
    image = build_file(str(DEMOS / name), entry_points=entry_points).image
    assert image is not None
    return image


OLD = image_of("blink.asi")
NEW = image_of("fb.asi")


def board_running(image: ProgramImage) -> Pc2Board:
    board = Pc2Board()
    download(Pc2Transport(Pc2Driver(EmulatedPort(board))), image, start=StartMode.START)
    board.advance(20)
    assert board.program is not None and board.control_flags & ControlFlag.START
    return board


def cut_points() -> tuple[list[int], int, int, int]:
    """Access counts to interrupt at; those from which the magic is gone, from which the
    header block is stored and from which the reset bit is written (a cut at N lets
    accesses 0..N-1 happen)."""
    port = InterruptingPort(EmulatedPort(board_running(OLD)))
    driver = RecordingDriver(port)
    download(Pc2Transport(driver), NEW, start=StartMode.START)
    points: set[int] = set()
    previous_end = 0
    downloads = []
    for code, start, end in driver.issued:
        points.update({start, start + 1, start + 3, end - 1, end, end + 1, end + 3})
        points.add((previous_end + start) // 2)  # mid-block: halfway into the buffer fill
        if code == Command.DOWNLOAD:
            downloads.append(end)
        previous_end = end
    reload = next(end for code, _, end in driver.issued if code == Command.WRITE_CONTROL_FLAGS)
    # the first 52 destroys the magic, the last one stores the header block
    return sorted(p for p in points if p < port.count), downloads[0], downloads[-1], reload


POINTS, MAGIC_GONE, HEADER_STORED, RELOADED = cut_points()


def test_the_download_writes_the_header_block_last():
    port = InterruptingPort(EmulatedPort(Pc2Board()))
    driver = RecordingDriver(port)
    writes: list[int] = []
    original = driver.command

    def command(code: int, data: int = 0, address: int = 0, ext: int = 0, **kw) -> int:
        if code == Command.DOWNLOAD:
            writes.append(address | ext << 8)
        return original(code, data, address, ext, **kw)

    driver.command = command  # type: ignore[method-assign]
    download(Pc2Transport(driver), NEW)
    size = len(NEW.to_bytes())
    assert size > 3 * 240, "the test needs an image of several blocks"
    assert writes == [0, *range(240, size, 240), 0]


@pytest.mark.parametrize("after", POINTS)
def test_an_interrupted_download_never_starts_half_a_program(after: int):
    board = board_running(OLD)
    port = InterruptingPort(EmulatedPort(board), after=after)
    with pytest.raises(Interrupted):
        download(Pc2Transport(Pc2Driver(port)), NEW, start=StartMode.START)

    board.advance(20)
    assert board.program is not None
    if after < RELOADED:
        assert board.program.program.code == OLD.code, "the previous program is still in RAM"
    else:
        assert board.program.program.code == NEW.code, "the download's own reset ran"

    transport = Pc2Transport(Pc2Driver(EmulatedPort(board)))
    try:
        reset(transport)
    except JobError as exc:
        assert exc.status is JobStatus.EEPROM_ERROR
        assert board.program is None and board.program_status is not ProgramStatus.LOADED
        assert MAGIC_GONE <= after < HEADER_STORED
    else:
        loaded = board.program.program.code
        if after < MAGIC_GONE:
            assert loaded == OLD.code, "nothing was written to the EEPROM yet"
        else:
            assert loaded == NEW.code and after >= HEADER_STORED, "complete, or nothing"

    download(transport, NEW, start=StartMode.START)
    board.advance(20)
    assert board.program.program.code == NEW.code
    assert board.control_flags & ControlFlag.START
