"""The live board itself: an emulated board whose master time follows the wall clock."""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable
from typing import Protocol

from asictl.board.board import Pc2Board
from asictl.errors import ExitCode, UserError
from asictl.host.live.changes import (
    ChangeLog,
    command_change,
    command_name,
    write_change,
    write_refused,
)
from asictl.host.live.protocol import JSON
from asictl.platform.pc2 import (
    ACK,
    ADDRESS_EXT,
    COMMAND,
    COMMAND_TIMEOUT_MS,
    NAK,
    PROGRAM_BUFFER,
    PROGRAM_BUFFER_SIZE,
    READ_ONLY_COMMANDS,
)

#: Master time one catch-up may run at most (after the process was stopped, say).
MAX_CATCH_UP_MS = 1000.0
#: Master time a command may take before the request returns without its acknowledge.
COMMAND_STEP_MS = 0.25


class Hold(Protocol):
    """What holds a live board (the debugger of ``asictl dap``'s attach): it lets master
    time pass in its own way (standing still while the program is paused), and turns
    away the emulated-only actions that would run or watch the program behind its back."""

    def advance(self, ms: float) -> None: ...

    def refusal(self, action: str) -> str | None: ...

    def halted(self) -> str | None:
        """While the master stands still: what holds it, and where (``halted at
        breakpoint line 6 by asictl dap (pid 7)``); None while it runs."""
        ...


class HeldBoard(UserError):
    """A change asked of a board a debugger holds halted: it would happen behind the
    debugger's back, or wait for a cycle that does not come (exit 1)."""

    exit_code = ExitCode.FAILED


class LiveBoard:
    """A ``Pc2Board`` whose master time follows ``clock`` (seconds, monotonic)."""

    def __init__(self, board: Pc2Board, clock: Callable[[], float] = time.monotonic) -> None:
        self.board = board
        self._clock = clock
        self._wall = clock()
        self._master = board.now_ms
        #: actions a server attached to this board adds or replaces (the gateway's panel),
        #: run on the loop instead of those of ``host.emulated.actions``
        self.actions: dict[str, Callable[[dict[str, JSON]], Awaitable[JSON]]] = {}
        #: the debugger holding the board, if one does
        self.hold: Hold | None = None
        #: keeps a change of the board's non-volatile state (on disk, saver.py): called
        #: after a request of a server attached to the board, before its answer; False
        #: if it could not (the answer must then not acknowledge the change)
        self.save_changes: Callable[[], bool] = lambda: True
        #: whether a command holds the board through the socket (a session): a server
        #: attached to the board that runs host commands of its own between the command's
        #: requests (the OPC UA server's refresh) waits until it is over
        self.in_session: Callable[[], bool] = lambda: False
        #: what clients changed, for the others' event logs
        self.changes = ChangeLog()

    def advance(self, ms: float) -> None:
        """Let ``ms`` of master time pass, through the hold if there is one."""
        if self.hold is not None:
            self.hold.advance(ms)
        else:
            self.board.advance(ms)

    def rebase(self) -> None:
        """Master time goes on from here: a board that stood still (held at a breakpoint)
        does not catch up with the pause."""
        self._wall, self._master = self._clock(), self.board.now_ms

    def sync(self) -> None:
        """Let master time catch up with the wall clock; a board that ran ahead (a command
        run to its acknowledge) waits until the wall clock has caught up instead."""
        target = self._master + (self._clock() - self._wall) * 1000
        lag = target - self.board.now_ms
        if lag > MAX_CATCH_UP_MS:  # the process stood still: do not replay the pause
            self._wall, self._master = self._clock(), self.board.now_ms + MAX_CATCH_UP_MS
            lag = MAX_CATCH_UP_MS
        if lag > 0:
            self.advance(lag)

    def halted(self) -> str | None:
        """What holds the master still (``Hold.halted``); None while it runs."""
        return self.hold.halted() if self.hold is not None else None

    def refuse_change(self, what: str) -> None:
        """``HeldBoard`` naming the holder if the master is halted: ``what`` would change it."""
        halted = self.halted()
        if halted is not None:
            raise HeldBoard(f"the board is {halted}: {what} would change it, and is not "
                            "done; continue or detach in the debugger first")

    def before_write(self, address: int, value: int, who: str) -> None:
        """``who`` is about to write ``value`` to the DPRAM at ``address``: noted if it is
        a change of data (changes.write_change). While the master is halted only a
        command's parameters and the program buffer may be written (what the commands
        that only read take), nothing the program or the master would read."""
        if address not in _PARAMETERS and address not in _BUFFER:
            self.refuse_change(write_refused(address, value))
        change = write_change(address, value)
        if change is not None:
            self.changes.note(change, who)

    def run_command(self, who: str = "this process") -> None:
        """Run the board until the command just written is acknowledged (or times out),
        and note the change it made as ``who``'s. A halted board answers a command that
        only reads at once, from the halted state, and refuses (FFh) and reports one that
        would change it (``HeldBoard``)."""
        board, waited = self.board, 0.0
        code = board.dpram_byte(COMMAND)
        if self.halted() is not None:
            read_only = code in READ_ONLY_COMMANDS
            board.answer_command(run=read_only)
            if not read_only:
                self.refuse_change(f"command {code}{command_name(code)}")
            return
        while board.dpram_byte(COMMAND) not in (ACK, NAK) and waited < COMMAND_TIMEOUT_MS:
            self.advance(COMMAND_STEP_MS)
            waited += COMMAND_STEP_MS
        change = command_change(board, code) if board.dpram_byte(COMMAND) == ACK else None
        if change is not None:
            self.changes.note(change, who)


#: What a command's caller writes: the command byte and its parameters, the program buffer.
_PARAMETERS = range(COMMAND, ADDRESS_EXT + 1)
_BUFFER = range(PROGRAM_BUFFER, PROGRAM_BUFFER + PROGRAM_BUFFER_SIZE)

