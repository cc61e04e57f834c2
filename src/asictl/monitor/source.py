"""What the monitor shows and does, apart from how it shows it.

Each refresh connects to the master as a command does (a live board through its socket,
one session per refresh; a real board or a gateway directly) and reads a ``MasterStatus``;
each action is one such connection too, so a monitor never holds a board between two
refreshes and other commands interleave with it. A master that cannot be reached is
reported, not fatal: the next refresh tries again.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

from asictl.errors import UserError
from asictl.host.connection import Master, MasterAddress, connect_master
from asictl.host.status import MasterStatus, ProgramInfo
from asictl.host.transfer import set_start
from asictl.platform.master import ControlFlag

#: The program image is read again every this many refreshes (it changes only by a
#: download, which the monitor sees as a change of identity anyway).
PROGRAM_EVERY = 20


@dataclass(frozen=True)
class Snapshot:
    """One refresh: the status, or why there is none."""

    status: MasterStatus | None
    error: str | None = None
    emulated: bool = False


class MonitorSource:
    """Reads and changes the master named by ``address``."""

    def __init__(
        self, address: MasterAddress, notify: Callable[[str], None] | None = None
    ) -> None:
        self.address = address
        self.notify = notify or (lambda text: None)
        self._program: ProgramInfo | None = None
        self._refreshes = 0
        #: a refresh and a key's action take turns (they run in worker threads)
        self._turn = threading.Lock()

    def snapshot(self) -> Snapshot:
        try:
            with self._turn, connect_master(self.address, notify=self.notify) as master:
                emulated = master.action is not None
                status = master.status() if self._needs_program() else self._quick(master)
        except UserError as exc:
            self._program = None
            return Snapshot(None, str(exc))
        self._program = status.program
        self._refreshes += 1
        return Snapshot(status, emulated=emulated)

    def _needs_program(self) -> bool:
        return self._program is None or self._refreshes % PROGRAM_EVERY == 0

    def _quick(self, master: Master) -> MasterStatus:
        """The status without reading the program image again (a PC2 board)."""
        if master.quick_status is None or self._program is None:
            return master.status()
        return master.quick_status(self._program)

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
