"""Where an emulated board keeps its EEPROM between commands.

A board is named by its I/O base (``--port 300h``, host/transports/ports.py). With the
emulated board (the default) every port is a board of its own whose non-volatile state
(EEPROM, flags, configuration) lives in a JSON file in the user's state directory, so a
download in one command is there for the upload in the next, as on a real master.

Each command holds an exclusive lock on the board (host/emulated/locking.py) from loading
the state to saving it, so two commands never interleave on one board; a command that
finds the board held says by whom and stops, or waits with ``--wait``; the state is
replaced in one rename, never half-written. A state file that cannot be read is reported
and left alone: replacing it silently would lose the program it may still hold.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from asictl.errors import ExitCode, UserError
from asictl.host.emulated.locking import exclusive
from asictl.host.emulated.state_files import prepare_folder, read_private, write_private
from asictl.host.transports.ports import port_name

if TYPE_CHECKING:
    from asictl.board.board import Pc2Board

STATE_DIR_ENV = "ASICTL_STATE_DIR"
#: Master time an emulated board runs after power-up before the host's first access: its
#: start-up (detection, activation, the config_ok delay) is over, as on a board that was
#: switched on before the command, and a status shows a settled master.
POWER_UP_MS = 100.0


def state_directory(override: str | Path | None = None) -> Path:
    """``--state-dir``, else ``$ASICTL_STATE_DIR``, else the XDG state directory."""
    if override:
        return Path(override)
    if os.environ.get(STATE_DIR_ENV):
        return Path(os.environ[STATE_DIR_ENV])
    xdg = os.environ.get("XDG_STATE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".local" / "state") / "asictl"


def state_file(directory: Path, base: int) -> Path:
    return directory / f"pc2-{port_name(base).lower()}.json"


def _load(path: Path) -> Pc2Board:
    # The board and its 8051 emulator load only here: a command that reaches a live
    # board needs only the names of its files.
    from asictl.board.board import Pc2Board

    raw = read_private(path)
    if raw is None:
        return Pc2Board()
    try:
        return Pc2Board.from_nonvolatile(json.loads(raw.decode("utf-8")))
    except (ValueError, RecursionError) as exc:  # JSONDecodeError and UnicodeDecodeError
        # are ValueErrors; deep nesting ([[[[...) exhausts the decoder's stack
        raise UserError(
            f"{path}: the emulated board's state is corrupt ({exc}); it is left as it is. "
            "Move it away to start again with a new, empty board."
        ) from None


def lock_file(directory: Path, base: int) -> Path:
    return state_file(directory, base).with_suffix(".lock")


@contextmanager
def emulated_board(
    base: int,
    directory: Path,
    *,
    wait: bool = False,
    notify: Callable[[str], None] | None = None,
    save: bool = True,
) -> Iterator[Pc2Board]:
    """The board at ``base``, powered up from its saved state (or new) under the lock,
    and saved when done (unless not ``save``: the live server saves it itself).

    A board another process holds (``gateway serve``, a long download) is a
    ``LockBusy`` naming the holder, unless ``wait``: then ``notify`` hears why the
    command waits. The state is saved however the block ends, an interruption included:
    what the commands did to the board until then is what a real board would keep. A
    save that fails says so plainly: the command's changes are then lost.
    """
    path = state_file(directory, base)
    prepare_folder(directory, warn=(lambda text: notify(f"warning: {text}")) if notify else None)
    with exclusive(lock_file(directory, base), f"board {port_name(base)}", wait=wait,
                   notify=notify):
        board = _load(path)
        board.advance(POWER_UP_MS)
        try:
            yield board
        finally:
            if save:
                try:
                    save_board(board, path)
                except UserError as exc:
                    raise UserError(
                        f"board {port_name(base)}: its state could not be saved ({exc}): "
                        "what this command changed on it is NOT saved", ExitCode.FAILED,
                    ) from None


def save_board(board: Pc2Board, path: Path) -> None:
    """The board's non-volatile state, private and on disk before this returns."""
    save_state(board.nonvolatile(), path)


def save_state(state: dict[str, Any], path: Path) -> None:
    """A board's non-volatile state (``Pc2Board.nonvolatile``), as ``save_board``."""
    text = json.dumps(state, indent=1, sort_keys=True) + "\n"
    write_private(path, text.encode("utf-8"))
