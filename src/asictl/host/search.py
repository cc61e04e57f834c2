"""``--port auto``: the board search of the manual's tools, ``AsiPc2Init(0)``.

"If zero is passed as I/O address, the driver searches for AS-i PC2 boards and uses the
first one found" (PC2 manual 9.3, line 719; ASI_MON and ASI_VIS do the same, lines 523 and
654). The search goes through the I/O bases 300h, 304h, ..., 32Ch in that order and
takes the first at which the manual's own board check ``CheckAsiPc2`` (10.3.3) finds a
board: 512 reads of the data register (wherever INDEX and PAGE point: they cover page 0)
must contain "AS-i PC2" with eight digits, the firmware's version ID, 64 bytes after it.

A real board is looked for through /dev/port at every base; an empty ISA address reads
FFh and is passed. Emulated boards exist where the state directory keeps one (its state
file, or the socket of a live board): each of those is checked through its own port, as a
command reaches it; one another process holds is there all the same.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from asictl.errors import ExitCode, UserError
from asictl.host.emulated.boards import emulated_board, state_file
from asictl.host.emulated.locking import LockBusy
from asictl.host.transports.driver import BlockPortIO, DevPort, EmulatedPort, PortIO
from asictl.host.transports.ports import parse_port, port_name
from asictl.platform.pc2 import IO_BASES, PORT_DATA

AUTO = "auto"
#: CheckAsiPc2's name string and how far it reads (10.3.3).
BOARD_NAME = b"AS-i PC2"
PROBE_SIZE = 512
VERSION_OFFSET = 64
VERSION_SIZE = 8
#: CheckAsiPc2's answers.
FOUND, WRONG_FIRMWARE, NOT_FOUND = 0, 2, 3


def check_board(port: PortIO) -> int:
    """``CheckAsiPc2`` at one port: FOUND, WRONG_FIRMWARE or NOT_FOUND."""
    if isinstance(port, BlockPortIO):
        pad = port.read_data(PROBE_SIZE)
    else:
        pad = bytes(port.read(PORT_DATA) for _ in range(PROBE_SIZE))
    at = pad.find(BOARD_NAME)
    if at < 0:
        return NOT_FOUND
    version = pad[at + VERSION_OFFSET : at + VERSION_OFFSET + VERSION_SIZE]
    if len(version) != VERSION_SIZE or not all(0x30 <= b <= 0x39 for b in version):
        return WRONG_FIRMWARE
    return FOUND


def _emulated(directory: Path, base: int) -> bool:
    """Is there an emulated board at ``base``, and does the board check find it?"""
    from asictl.host.live.client import LivePort, open_live
    from asictl.host.live.protocol import socket_path

    if not (state_file(directory, base).exists() or socket_path(directory, base).exists()):
        return False
    client = open_live(directory, base)
    if client is not None:
        try:
            return check_board(LivePort(client)) == FOUND
        finally:
            client.close()
    try:
        with emulated_board(base, directory) as board:
            return check_board(EmulatedPort(board)) == FOUND
    except LockBusy:
        return True  # held by a command running on it: the board is there


def _real(base: int) -> bool:
    device = DevPort(base)
    try:
        return check_board(device) == FOUND
    finally:
        device.close()


def find_board(
    io: str, directory: Path, *, probe: Callable[[int], bool] | None = None,
) -> tuple[int, list[int]]:
    """The first base a board answers at, and the bases searched before it without one."""
    look = probe or (_real if io == "devport" else lambda base: _emulated(directory, base))
    passed: list[int] = []
    for base in IO_BASES:
        if look(base):
            return base, passed
        passed.append(base)
    where = "through /dev/port" if io == "devport" else f"among the emulated boards in {directory}"
    raise UserError(
        f"--port auto: no PC2 board found at {', '.join(port_name(b) for b in IO_BASES)} "
        f"({where})" + ("" if io == "devport" else "; give --port to make one"),
        ExitCode.FAILED,
    )


def resolve_port(
    text: str, io: str, directory: Path, notify: Callable[[str], None] | None = None
) -> int:
    """``--port``: a base as written, or with ``auto`` the first board found (said on
    ``notify``)."""
    if text.strip().lower() != AUTO:
        return parse_port(text)
    base, passed = find_board(io, directory)
    if notify is not None:
        searched = f" (none at {', '.join(port_name(b) for b in passed)})" if passed else ""
        notify(f"--port auto: found a PC2 board at {port_name(base)}{searched}")
    return base
