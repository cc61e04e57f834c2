"""The live board's state on disk: every change a client made is saved before the client
hears that it was made.

A command that changes what survives power-off (a download block, ``store``, setup, a
slave's stored parameters, the non-volatile flags, the emulated cable) is acknowledged
only once that state is on disk: ``save_changes`` runs after every request and compares
the board's non-volatile state with the one last saved (about 50 µs), and writes it in
one private, fsync'd rename when they differ. So a ``kill -9`` of the server loses
nothing a client was told is done. Whatever changes without a request (the control
program's own doings) is saved every ``interval`` seconds, and everything at the end.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from asictl.board.board import Pc2Board
from asictl.errors import ExitCode, UserError
from asictl.host.condition_log import ConditionLog
from asictl.host.emulated.boards import save_state

#: Changes no request made are saved this often while the board runs (and at the end).
SAVE_INTERVAL_S = 10.0


class NotSaved(UserError):
    """The board's state could not be written: what changed since is not safe."""

    exit_code = ExitCode.FAILED


class StateKeeper:
    """Keeps ``path`` equal to the board's non-volatile state."""

    def __init__(
        self, board: Pc2Board, path: Path, *, interval: float = SAVE_INTERVAL_S,
        notify: Callable[[str], None] | None = None,
    ) -> None:
        self.board = board
        self.path = path
        self.interval = interval
        self._saved: dict[str, Any] | None = None
        self._saved_at: float | None = None
        self._due = time.monotonic() + interval
        self._failing = False
        self._log = notify or (lambda message: None)
        self._conditions = ConditionLog(self._log)

    @property
    def last_saved(self) -> dict[str, Any] | None:
        """The state as last written (None before the first save)."""
        return self._saved

    @property
    def unsaved(self) -> bool:
        """Whether the board holds changes the file does not."""
        return self.board.nonvolatile() != self._saved

    def save_changes(self) -> None:
        """Save the state if it changed since the last save; ``NotSaved`` if it cannot be
        written (the change must then not be acknowledged as safe)."""
        state = self.board.nonvolatile()
        if state != self._saved:
            self._write(state)

    def saved(self) -> bool:
        """``save_changes`` for a server that answers in its own protocol (the Modbus
        gateway): False if the state could not be saved (logged once, then at most once
        a minute)."""
        try:
            self.save_changes()
        except NotSaved as exc:
            self._conditions.event("save", f"cannot save the board state ({exc}); a "
                                   "change is answered as a failure until it can")
            return False
        return True

    def save(self) -> None:
        """Save the state whether or not it changed (its file may have gone)."""
        self._write(self.board.nonvolatile())

    def _write(self, state: dict[str, Any]) -> None:
        try:
            save_state(state, self.path)
        except UserError as exc:
            self._failing = True
            raise NotSaved(str(exc)) from None
        self._saved, self._saved_at = state, time.time()
        if self._failing:
            self._failing = False
            self._log(f"the board state is saved again in {self.path}")

    def tick(self) -> None:
        """Save what changed by itself, every ``interval`` seconds; a save that fails (the
        state directory removed, the disk full) does not end the serving: it is logged
        once, then at most once a minute, and tried again at the next interval."""
        if time.monotonic() < self._due:
            return
        self._due = time.monotonic() + self.interval
        try:
            self.save_changes()
        except NotSaved as exc:
            self._conditions.event("save", f"cannot save the board state ({exc}); trying "
                                   f"again every {self.interval:g} s, still serving")

    def final(self, what: str) -> None:
        """The save when serving ends; ``NotSaved`` saying plainly what is lost if it
        fails (``what`` names the board)."""
        unsaved = self.unsaved
        try:
            self.save()
        except NotSaved as exc:
            since = (
                time.strftime("%H:%M:%S", time.localtime(self._saved_at))
                if self._saved_at is not None else None
            )
            if unsaved:
                lost = "its last changes were NOT saved" + (
                    f" (the state file holds it as of {since})" if since else ""
                )
            else:
                lost = "nothing had changed since it was last saved" + (
                    f" at {since}" if since else ""
                ) + f", but check that {self.path} is still there"
            raise NotSaved(f"{what} stopped, but its state could not be saved ({exc}): "
                           f"{lost}") from None
