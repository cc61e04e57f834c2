"""What the monitor shows and does, apart from how it shows it.

Each refresh connects to the master as a command does (a live board through its socket,
one session per refresh; a real board or a gateway directly) and reads a ``MasterStatus``;
each action is one such connection too, so a monitor never holds a board between two
refreshes and other commands interleave with it. A master that cannot be reached is
reported, not fatal: the next refresh tries again.

The program image is read now and then and kept (``StoredProgram``): it names the IL
line of a cycle time-out, and the program view shows its source. While the program view
is open (``watch_lines``) each refresh also asks an emulated board for the IL lines of
its latest program cycle (``observe.online``); a real board or a gateway has none to give.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

from asictl.errors import UserError
from asictl.host.connection import MasterAddress, connect_master
from asictl.host.master import Master
from asictl.host.status import MasterStatus, StoredProgram, read_program
from asictl.host.transfer import set_start
from asictl.observe.online import CycleLines
from asictl.platform.master import ControlFlag

#: The program image is read again every this many refreshes (it changes only by a
#: download, which the monitor sees as a change of identity anyway).
PROGRAM_EVERY = 20
#: Why a real board has no per-line values, and a gateway none either.
NO_LINES_REAL = (
    "per-line values need an emulated board: a real PC2's firmware reports none"
)
NO_LINES_GATEWAY = (
    "per-line values need an emulated board: a gateway reports none (for the emulated "
    "gateway, 'asictl monitor --port' on the board it serves shows them)"
)


@dataclass(frozen=True)
class Snapshot:
    """One refresh: the status, or why there is none."""

    status: MasterStatus | None
    error: str | None = None
    emulated: bool = False
    #: the EEPROM's program as last read
    program: StoredProgram | None = None
    #: the latest cycle's IL lines, while the program view is open on an emulated board
    lines: CycleLines | None = None
    #: why there are no per-line values (a real board, a gateway)
    lines_note: str | None = None


class MonitorSource:
    """Reads and changes the master named by ``address``."""

    def __init__(
        self, address: MasterAddress, notify: Callable[[str], None] | None = None
    ) -> None:
        self.address = address
        self.notify = notify or (lambda text: None)
        self._program: StoredProgram | None = None
        self._refreshes = 0
        #: the program view is open: each refresh asks for the latest cycle's lines
        self.watch_lines = False
        #: a refresh and a key's action take turns (they run in worker threads)
        self._turn = threading.Lock()

    def snapshot(self) -> Snapshot:
        try:
            with self._turn, connect_master(self.address, notify=self.notify) as master:
                emulated = master.action is not None
                status = self._status(master)
                lines, note = self._lines(master) if self.watch_lines else (None, None)
        except UserError as exc:
            self._program = None
            return Snapshot(None, str(exc))
        self._refreshes += 1
        program = self._program
        if lines is not None and program is not None and lines.identity != program.info.identity:
            self._program = None  # a download meanwhile: read the new image next time
        return Snapshot(
            status, emulated=emulated, program=program, lines=lines, lines_note=note
        )

    def _status(self, master: Master) -> MasterStatus:
        """A PC2 board's status with the image kept (read again every ``PROGRAM_EVERY``
        refreshes); a gateway reads its own status, and the image only when the program
        view needs it and the program changed."""
        if master.quick_status is not None:
            if self._program is None or self._refreshes % PROGRAM_EVERY == 0:
                self._program = read_program(master.transport)
            return master.quick_status(self._program)
        status = master.status()
        if self.watch_lines and (
            self._program is None or self._program.info.identity != status.program.identity
        ):
            self._program = read_program(master.transport)
        return status

    @staticmethod
    def _lines(master: Master) -> tuple[CycleLines | None, str | None]:
        if master.action is None:
            return None, NO_LINES_REAL if master.driver is not None else NO_LINES_GATEWAY
        return CycleLines.from_json(master.emulated("lines")), None

    def reload_program(self) -> None:
        """F9: read everything again at the next refresh."""
        self._program = None

    def run(self, what: str, action: Callable[[Master], str | None]) -> str:
        """Do ``action`` on the master; a line for the event log, failures included."""
        try:
            with self._turn, connect_master(self.address, notify=self.notify) as master:
                result = action(master)
        except UserError as exc:
            return f"{what}: {exc}"
        return result or what


def toggle_start(master: Master) -> str:
    """s: start a stopped program, stop a running one (the start flag)."""
    running = bool(master.transport.control_flags() & ControlFlag.START)
    set_start(master.transport, start=not running)
    return "stop: start flag cleared" if running else "start: start flag set"
