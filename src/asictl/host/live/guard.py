"""The live server's hold on its place in the state folder.

While ``serve`` runs, its board lives in memory and the state folder holds its lock, its
state file and its socket. Should the folder (or one of them) be removed, a command
would find no socket, make a new board beside the live one, and the live server's next
save would silently overwrite it. So the server looks every ``WATCH_S`` seconds
(``StatePlace.check``, a few ``stat`` calls): what is gone is made again at once (the
folder 0700, the lock taken on the new lock file, the state saved); when another
process got there first (it holds the new lock, or wrote a state file that is not the
live board's), the server stops and leaves that board alone, its own state saved beside
it under a name of its own.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path

from asictl.errors import ExitCode, UserError
from asictl.host.emulated.boards import lock_file, state_file
from asictl.host.emulated.locking import LockBusy, exclusive, note_holder
from asictl.host.emulated.state_files import prepare_folder, read_private
from asictl.host.live.saver import StateKeeper
from asictl.host.transports.ports import port_name

#: How often the server looks whether its folder, lock, state file and socket are there.
WATCH_S = 0.2

Identity = tuple[int, int] | None


def identity(path: Path) -> Identity:
    """The file ``path`` names (device and inode, not following a link); None if none."""
    try:
        info = os.lstat(path)
    except OSError:
        return None
    return info.st_dev, info.st_ino


class PlaceTaken(UserError):
    """The live board's place was taken by another board while it was gone."""

    exit_code = ExitCode.FAILED


class StatePlace:
    """The folder, lock and state file of a live board, put back when removed."""

    def __init__(
        self, directory: Path, base: int, keeper: StateKeeper, note: str,
        notify: Callable[[str], None] | None = None,
    ) -> None:
        self.directory = directory
        self.base = base
        self.keeper = keeper
        self.note = note
        self._log = notify or (lambda message: None)
        self._lock = lock_file(directory, base)
        self._folder_id = identity(directory)
        self._lock_id = identity(self._lock)
        self._locks = ExitStack()

    def close(self) -> None:
        """Let go of the locks taken again while serving."""
        self._locks.close()

    def check(self) -> None:
        """Put back what was removed; ``PlaceTaken`` if another board took its place."""
        folder_there = identity(self.directory) == self._folder_id
        lock_there = folder_there and identity(self._lock) == self._lock_id
        state = self.keeper.path
        if lock_there and identity(state) is not None:
            return
        gone = (
            f"the state directory {self.directory}" if not folder_there
            else f"the lock file {self._lock}" if not lock_there
            else f"the state file {state}"
        )
        name = f"board {port_name(self.base)}"
        prepare_folder(self.directory)
        self._folder_id = identity(self.directory)
        if not lock_there:
            try:
                self._locks.enter_context(exclusive(self._lock, name))
            except LockBusy as exc:
                by = exc.holder.describe() if exc.holder else "another process"
                raise self._taken(f"{by} holds {name} in it") from None
            self._lock_id = identity(self._lock)
            note_holder(self._lock, self.note)
        found = read_private(state)
        if found is not None and not self._ours(found):
            raise self._taken(f"a board that is not the live one was saved there ({state})")
        self.keeper.save()
        self._log(f"{gone} was removed while {name} is served live: made it again, with "
                  "the board's lock and state")

    def _ours(self, raw: bytes) -> bool:
        try:
            return bool(json.loads(raw.decode("utf-8")) == self.keeper.last_saved)
        except ValueError:
            return False

    def _taken(self, what: str) -> PlaceTaken:
        """Stop serving, the live board's state kept beside the other board's."""
        aside = state_file(self.directory, self.base).with_suffix(f".live-{os.getpid()}.json")
        self.keeper.path = aside
        return PlaceTaken(
            f"the state directory {self.directory} was removed under the live board, and "
            f"meanwhile {what}: the live board stops and leaves it alone; its own state is "
            f"saved as {aside}"
        )
