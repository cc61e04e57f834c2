"""git's lock files a killed git run leaves in the archive, and whether one is stale.

git takes ``index.lock`` (and ``HEAD.lock``, a branch's ``refs/heads/NAME.lock``, the
``next-index-PID.lock`` of a commit of some paths) for the length of one command and
removes it at the end; a git killed with SIGKILL (or a power cut) leaves it, and every
later git command on the repository refuses to run. A lock is
stale, and removed, only when that can be proved: no git process works in the
repository (none has its current folder there, none holds the lock file open) and the
lock is older than ``SETTLED_S``. Proving it needs ``/proc`` (Linux); elsewhere, or when
a git process is alive, the lock stays and the message says how to remove it by hand.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from asictl.errors import ExitCode, UserError

#: A lock younger than this may belong to a git that is starting: it is never removed.
SETTLED_S = 2.0
_PROC = Path("/proc")


def git_locks(root: Path) -> list[Path]:
    """The lock files git left in the repository at ``root``."""
    git = root / ".git"
    found = [git / name for name in ("index.lock", "HEAD.lock") if (git / name).exists()]
    found += sorted(git.glob("next-index-*.lock"))  # a ``commit --only``'s own index
    heads = git / "refs" / "heads"
    if heads.is_dir():
        found += sorted(heads.rglob("*.lock"))
    return found


def _inside(path: str, root: Path) -> bool:
    return path == str(root) or path.startswith(f"{root}{os.sep}")


def _git_at_work(root: Path, locks: list[Path]) -> int | None:
    """The id of a process that works in the repository (a ``git`` whose current folder
    is in it, or any process holding one of ``locks`` open); None when there is none."""
    real = root.resolve()
    held = {str(lock.resolve()) for lock in locks}
    for entry in _PROC.iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            if (entry / "comm").read_text().startswith("git") and _inside(
                os.readlink(entry / "cwd"), real
            ):
                return int(entry.name)
            for fd in (entry / "fd").iterdir():
                if os.readlink(fd) in held:
                    return int(entry.name)
        except OSError:  # gone meanwhile, or another user's: not one of ours at work
            continue
    return None


def clear_stale_locks(root: Path) -> list[Path]:
    """Remove git's locks in ``root`` that no git holds; returns those removed. A lock
    that may be held (or whose staleness cannot be proved) is a ``UserError`` saying
    which and how to remove it."""
    locks = git_locks(root)
    if not locks:
        return []
    if not _PROC.is_dir():
        why = "whether a git process holds it cannot be told on this system"
    elif (pid := _git_at_work(root, locks)) is not None:
        why = f"process {pid} works in the archive"
    elif any(time.time() - lock.stat().st_mtime < SETTLED_S for lock in locks):
        why = "it was taken a moment ago"
    else:
        for lock in locks:
            lock.unlink(missing_ok=True)
        return locks
    raise UserError(
        f"{locks[0]}: git's lock is held or may be ({why}); when no git runs on the "
        f"archive, remove it ({' '.join(f'rm {lock}' for lock in locks)}) and run again",
        ExitCode.FAILED,
    )
