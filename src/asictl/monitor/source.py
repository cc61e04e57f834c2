"""What the monitor shows and does, apart from how it shows it.

Each refresh connects to the master as a command does (a live board through its socket,
one session per refresh; a real board or a gateway directly) and reads a ``MasterStatus``;
each action is one such connection too, so a monitor never holds a board between two
refreshes and other commands interleave with it. A master that cannot be reached is
reported, not fatal: the next refresh tries again.

An emulated board is only ever shown live: a board loaded from its state file for one
refresh would not run, and the view would say "running" of a program nothing runs. So
when no live server keeps the board (at the start, or because the one that did went
away: stopped, killed, its place in the state folder taken), the source serves it itself
from a thread (``background_live``): it *takes over*, and says so. When it cannot (the
board's lock is held by another process), the master is *gone* until it can; the screen
says so in red and refuses the keys that act on the board.

Each refresh of a live board also asks what other clients changed on it since the last
(host.live.changes), for the event log: ``FORCE Q 3.1 (PumpB)=1 by asictl force (pid
7)``, ``debugger attached by asictl dap (pid 8)``; reads are never changes, so another
monitor's refreshes never show.

The program image is read now and then and kept (``StoredProgram``): it names the IL
line of a cycle time-out, and the program view shows its source. While the program view
is open (``watch_lines``) each refresh also asks an emulated board for the IL lines of
its latest program cycle (``observe.online``); a real board or a gateway has none to give.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass

from asictl.errors import UserError
from asictl.host.connection import MasterAddress, NotServed, client_name, open_board
from asictl.host.emulated.boards import lock_file, state_directory
from asictl.host.emulated.locking import is_free, read_holder
from asictl.host.live.client import LiveActions, LiveClient
from asictl.host.live.server import background_live
from asictl.host.master import Master
from asictl.host.status import MasterStatus, StoredProgram, read_program
from asictl.host.transfer import set_start
from asictl.host.transports.ports import parse_port, port_name
from asictl.observe.online import CycleLines
from asictl.platform.master import ControlFlag

#: How the monitor's own live server names itself, and how the screen names it.
OWN_SERVER = "asictl monitor"
THIS_MONITOR = "this monitor"
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


def _unheard(text: str) -> None:
    """Where a refresh's waits go."""


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
    #: who keeps an emulated board running ("this monitor", "asictl serve (pid 7)")
    served_by: str | None = None
    #: when this monitor took over serving the board (None: it did not)
    took_over: float | None = None
    #: what happened to the serving since the last refresh, for the event log
    events: tuple[str, ...] = ()


class MonitorSource:
    """Reads and changes the master named by ``address``."""

    def __init__(
        self, address: MasterAddress, notify: Callable[[str], None] | None = None
    ) -> None:
        self.address = address
        self.notify = notify or (lambda text: None)
        #: an emulated PC2 board: shown live only, served here when nobody else does
        self.emulated_port = address.modbus is None and address.io == "emulated"
        self._serving = ExitStack()
        self._served_by: str | None = None
        self._took_over: float | None = None
        self._program: StoredProgram | None = None
        self._refreshes = 0
        #: the live board's latest change this monitor has logged (None: none yet)
        self._changes_seen: int | None = None
        #: the program view is open: each refresh asks for the latest cycle's lines
        self.watch_lines = False
        #: a refresh and a key's action take turns (they run in worker threads)
        self._turn = threading.Lock()

    def snapshot(self) -> Snapshot:
        events: list[str] = []
        try:
            with self._turn:
                try:
                    return self._read(events)
                except NotServed:
                    self._take_over(events)
                    return self._read(events)
        except UserError as exc:
            self._program = None
            return Snapshot(None, str(exc), served_by=self._served_by,
                            took_over=self._took_over, events=tuple(events))

    def _read(self, events: list[str]) -> Snapshot:
        """One refresh; ``NotServed`` if nobody keeps the emulated board running. A wait
        for the board (another client holds it) is no event: the next refresh comes
        anyway, and the log would fill with them while a recorder or a debugger works."""
        with open_board(
            self.address, notify=_unheard, live_only=self.emulated_port
        ) as master:
            emulated = master.action is not None
            served = master.action.live if master.action is not None else None
            status = self._status(master)
            lines, note = self._lines(master) if self.watch_lines else (None, None)
            if isinstance(master.action, LiveActions):
                events += self._changes(master.action.client)
        if served == f"{OWN_SERVER} (pid {os.getpid()})":
            served = THIS_MONITOR
        if served is not None and served != self._served_by:
            if self._served_by is not None:
                events.append(f"board {status.port} is served by {served} now")
            self._served_by = served
        self._refreshes += 1
        program = self._program
        if lines is not None and program is not None and lines.identity != program.info.identity:
            self._program = None  # a download meanwhile: read the new image next time
        return Snapshot(
            status, emulated=emulated, program=program, lines=lines, lines_note=note,
            served_by=self._served_by, took_over=self._took_over, events=tuple(events),
        )

    def _changes(self, client: LiveClient) -> list[str]:
        """What other clients changed on the live board since the last refresh (this
        monitor's own keys are logged as they are pressed)."""
        changes, self._changes_seen = client.changes(self._changes_seen)
        me = client_name()
        return [f"{change.text} by {change.who}" for change in changes if change.who != me]

    def _take_over(self, events: list[str]) -> None:
        """Serve the board from this process; ``UserError`` if another process holds it."""
        self._serving.close()  # a server of ours that stopped by itself
        directory = state_directory(self.address.state_dir)
        base = parse_port(self.address.port)
        name = port_name(base)
        before = self._served_by
        try:
            self._serving.enter_context(background_live(
                base, directory, identity={"command": OWN_SERVER, "port": name},
            ))
        except UserError as exc:
            what = (
                "the monitor's own live board stopped" if before == THIS_MONITOR
                else f"{before} went away" if before else "no live board serves it"
            )
            lock = lock_file(directory, base)
            if is_free(lock):
                why = str(exc)
            else:  # the monitor tries again each refresh: no hint to run anything again
                holder = read_holder(lock)
                by = f"process {holder.pid} ({holder.command})" if holder else "another process"
                why = f"board {name} is in use by {by}; taken over once it is free"
            raise UserError(f"{what}, and the monitor cannot take over: {why}") from None
        self._served_by = THIS_MONITOR
        if before is None:
            events.append(
                f"no live board was running for {name}: the monitor keeps it running "
                "while it runs"
            )
            return
        self._took_over = time.time()
        events.append(
            f"took over: {before} went away; this monitor serves board {name} now "
            f"(quitting it stops the board: 'asictl serve' keeps it running)"
        )

    def close(self) -> None:
        """Stop serving the board, if this monitor serves it."""
        with self._turn:
            self._serving.close()

    def __enter__(self) -> MonitorSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

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
            with self._turn, open_board(
                self.address, notify=self.notify, live_only=self.emulated_port
            ) as master:
                result = action(master)
        except UserError as exc:
            return f"{what}: {exc}"
        return result or what


def toggle_start(master: Master) -> str:
    """s: start a stopped program, stop a running one (the start flag)."""
    running = bool(master.transport.control_flags() & ControlFlag.START)
    set_start(master.transport, start=not running)
    return "stop: start flag cleared" if running else "start: start flag set"
