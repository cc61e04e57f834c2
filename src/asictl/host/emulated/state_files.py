"""The state folder of emulated boards, kept as private as ``~/.ssh``.

A board's state file holds its EEPROM, and so the exact source of the program on it: any
other local user who can read it can upload that program, and one who can write the
folder can plant a link or a socket there that makes the owner's next command overwrite
one of the owner's files or talk to the other user's board. So:

- the folder is created 0700 and every file in it 0600, whatever the umask;
- a folder that another user owns, or that anyone but its owner can write, is refused
  (as ssh refuses a loose ``~/.ssh``); one that others can only read or enter is used,
  with a warning, and never widened or narrowed behind the user's back;
- files there are opened without following links (``O_NOFOLLOW``), new ones made with
  ``O_EXCL``, and replaced by renaming a private temporary file over the name itself (a
  link planted there is replaced, its target never written).
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path

from asictl.errors import UserError

#: Owner only.
FOLDER_MODE = 0o700
FILE_MODE = 0o600
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)


class UnsafeStateFolder(UserError):
    """A state folder that other users could use to read, lock or redirect a board."""


def prepare_folder(folder: Path, warn: Callable[[str], None] | None = None) -> Path:
    """``folder``, created owner-only if it is not there; refused if it is unsafe.

    ``warn`` hears about a folder others can read (its files stay 0600 all the same).
    """
    try:
        folder.mkdir(mode=FOLDER_MODE, parents=True)
        os.chmod(folder, FOLDER_MODE)  # mkdir's mode passes through the umask
    except FileExistsError:
        pass
    except OSError as exc:
        raise UserError(f"{folder}: cannot use as state directory: {exc.strerror or exc}") from None
    return check_folder(folder, warn)


def check_folder(folder: Path, warn: Callable[[str], None] | None = None) -> Path:
    """``folder`` as ``prepare_folder`` finds it, made by nobody: refused if unsafe."""
    try:
        info = os.stat(folder)
    except OSError as exc:
        raise UserError(f"{folder}: cannot use as state directory: {exc.strerror or exc}") from None
    if not stat.S_ISDIR(info.st_mode):
        raise UserError(f"{folder}: cannot use as state directory: it is not a directory")
    if info.st_uid != os.geteuid():
        raise UnsafeStateFolder(
            f"{folder}: the state directory belongs to another user (uid {info.st_uid}): "
            "its boards are not yours to use; give --state-dir (or ASICTL_STATE_DIR) a "
            "folder of your own"
        )
    if info.st_mode & 0o022:
        raise UnsafeStateFolder(
            f"{folder}: other users can write the state directory "
            f"(mode {stat.S_IMODE(info.st_mode):04o}), so they could plant files there that "
            f"redirect your commands: make it yours alone (chmod 700 {folder})"
        )
    if info.st_mode & 0o055 and warn is not None:
        warn(
            f"{folder}: other users can look into the state directory (mode "
            f"{stat.S_IMODE(info.st_mode):04o}); its files are private all the same "
            f"(chmod 700 {folder} hides even their names)"
        )
    return folder


def read_private(path: Path) -> bytes | None:
    """A state file's bytes, ``None`` if there is none; a link there is refused."""
    try:
        fd = os.open(path, os.O_RDONLY | _NOFOLLOW | _CLOEXEC)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise UserError(f"{path}: cannot read: {_reason(exc)}") from None
    with os.fdopen(fd, "rb") as file:
        try:
            return file.read()
        except OSError as exc:
            raise UserError(f"{path}: cannot read: {exc.strerror or exc}") from None


def write_private(path: Path, data: bytes) -> None:
    """Replace ``path`` with ``data`` in one rename, 0600, synced to disk before the
    rename (and the folder after it), so that what was acknowledged survives a crash."""
    try:
        fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as exc:
        raise UserError(f"{path}: cannot write: {exc.strerror or exc}") from None
    temp = Path(name)
    try:
        with os.fdopen(fd, "wb") as out:  # mkstemp: O_EXCL, mode 0600
            out.write(data)
            out.flush()
            os.fsync(out.fileno())
        os.replace(temp, path)  # a link at ``path`` is replaced, its target untouched
    except OSError as exc:
        temp.unlink(missing_ok=True)
        raise UserError(f"{path}: cannot write: {exc.strerror or exc}") from None
    _sync_folder(path.parent)


def open_private(path: Path) -> int:
    """A descriptor of ``path`` for reading and writing (a lock file), made 0600 if new;
    a link there, or a file of another user, is refused."""
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | _NOFOLLOW | _CLOEXEC, FILE_MODE)
    except OSError as exc:
        raise UserError(f"{path}: cannot open: {_reason(exc)}") from None
    info = os.fstat(fd)
    if info.st_uid != os.geteuid() or not stat.S_ISREG(info.st_mode):
        os.close(fd)
        raise UnsafeStateFolder(f"{path}: not a file of yours; it is left alone")
    if info.st_mode & 0o077:
        os.fchmod(fd, FILE_MODE)  # made by an older asictl under the umask
    return fd


def _reason(exc: OSError) -> str:
    if exc.errno == errno.ELOOP:
        return "it is a symbolic link, which a state directory never holds"
    return exc.strerror or str(exc)


def _sync_folder(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY | _CLOEXEC)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass  # some file systems cannot sync a folder; the rename is still atomic
    finally:
        os.close(fd)
