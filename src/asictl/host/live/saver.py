"""The live board's state saved now and then while it runs, so that a crash or a power
cut loses at most the last interval (the server saves once more when serving ends)."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

from asictl.board.board import Pc2Board
from asictl.errors import UserError
from asictl.files import write_atomic
from asictl.host.condition_log import ConditionLog

#: The board's non-volatile state is written this often while it runs (and at the end).
SAVE_INTERVAL_S = 10.0


def state_saver(
    board: Pc2Board, path: Path, *, interval: float = SAVE_INTERVAL_S,
    notify: Callable[[str], None] | None = None,
) -> Callable[[], None]:
    """Writes the board's non-volatile state when ``interval`` seconds have passed.

    A save that fails (the state directory removed, the disk full) must not end the
    serving: it is logged (once, then at most once a minute) and tried again at the next
    interval, and a line says when a save succeeds again.
    """
    saved = [time.monotonic()]
    failing = [False]
    log = notify or (lambda message: None)
    conditions = ConditionLog(log)

    def save_now_and_then() -> None:
        if time.monotonic() - saved[0] < interval:
            return
        saved[0] = time.monotonic()
        text = json.dumps(board.nonvolatile(), indent=1, sort_keys=True)
        try:
            write_atomic(path, text + "\n")
        except UserError as exc:
            failing[0] = True
            conditions.event("save", f"cannot save the board state ({exc}); trying again "
                             f"every {interval:g} s, still serving")
            return
        if failing[0]:
            failing[0] = False
            log(f"the board state is saved again in {path}")

    return save_now_and_then
