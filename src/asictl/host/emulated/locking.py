"""An exclusive lock that says who holds it.

A command that finds a board in use should not wait in silence (``gateway serve`` may
hold it for days): it reports the holder and stops, or waits when asked to and says so.
The lock is a ``flock`` on a file, so the kernel releases it whatever way its holder
ends; beside the lock file a small JSON file names the holder (pid, command line, since
when, and what it offers, e.g. the address a gateway serves), written once the lock is
taken and removed before it is released. A holder file left behind by a process that was
killed names a process that no longer holds the lock: it is only read while the lock is
held, and the next holder overwrites it.
"""

from __future__ import annotations

import fcntl
import json
import os
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from asictl.errors import ExitCode, UserError
from asictl.host.emulated.state_files import open_private, read_private, write_private


@dataclass(frozen=True)
class Holder:
    """Who holds a lock."""

    pid: int
    command: str
    #: seconds since the epoch when it took the lock
    since: float
    #: what the holder offers meanwhile (e.g. "serving Modbus at tcp://127.0.0.1:5020")
    note: str = ""

    def describe(self) -> str:
        started = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(self.since))
        text = f"process {self.pid} ({self.command}) since {started}"
        return f"{text}; {self.note}" if self.note else text


class LockBusy(UserError):
    """The lock is held by another process and the caller chose not to wait."""

    exit_code = ExitCode.FAILED

    def __init__(self, message: str, holder: Holder | None) -> None:
        super().__init__(message)
        self.holder = holder


def holder_file(lock_path: Path) -> Path:
    return lock_path.with_suffix(".holder")


def read_holder(lock_path: Path) -> Holder | None:
    """The holder the file beside ``lock_path`` names (None if it names none)."""
    try:
        raw = read_private(holder_file(lock_path))
        if raw is None:
            return None
        fields = json.loads(raw.decode("utf-8"))
        return Holder(
            int(fields["pid"]), str(fields["command"]), float(fields["since"]),
            str(fields.get("note", "")),
        )
    except (UserError, ValueError, KeyError, TypeError):
        return None


def _command_line() -> str:
    name = Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "python"
    if name in ("__main__.py", "-c", ""):
        name = "asictl"
    return " ".join([name, *sys.argv[1:]])


def _write_holder(lock_path: Path, holder: Holder) -> None:
    write_private(holder_file(lock_path), (json.dumps(asdict(holder)) + "\n").encode())


def note_holder(lock_path: Path, note: str) -> None:
    """Tell commands that find the lock held what this process offers meanwhile (only
    while this process holds it)."""
    holder = read_holder(lock_path)
    if holder is not None and holder.pid == os.getpid():
        _write_holder(lock_path, replace(holder, note=note))


def is_free(lock_path: Path) -> bool:
    """Nobody holds the lock now (False too if its file cannot be opened)."""
    try:
        fd = open_private(lock_path)
    except UserError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    finally:
        os.close(fd)  # closing releases a lock taken here
    return True


@contextmanager
def exclusive(
    lock_path: Path,
    what: str,
    *,
    wait: bool = False,
    notify: Callable[[str], None] | None = None,
) -> Iterator[None]:
    """Hold the lock on ``lock_path`` for the block; ``what`` names the thing it guards.

    Held elsewhere: without ``wait`` a ``LockBusy`` (exit status 1) says by whom; with
    ``wait``, ``notify`` is told so and the call blocks until the holder lets go.
    """
    lock = os.fdopen(open_private(lock_path), "r+b")  # held for the whole block
    with lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = read_holder(lock_path)
            by = holder.describe() if holder else "another process"
            if not wait:
                raise LockBusy(
                    f"{what} is in use by {by}; run the command again when it is done, "
                    "or give --wait to wait for it",
                    holder,
                ) from None
            if notify is not None:
                notify(f"{what} is in use by {by}; waiting for it (--wait)")
            fcntl.flock(lock, fcntl.LOCK_EX)
        _write_holder(lock_path, Holder(os.getpid(), _command_line(), time.time()))
        try:
            yield
        finally:
            with suppress(OSError):
                holder_file(lock_path).unlink()
