"""Writing output files so that a failure never leaves a half-written one behind.

A HEX image that is cut short would still look plausible to a programmer tool, so
every output is written to a temporary file in the target directory and renamed over
the target only when complete (a rename within one directory is atomic).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from asictl.errors import UserError


def write_atomic(path: str | Path, data: str | bytes) -> None:
    """Replace ``path`` with ``data`` (text is written as UTF-8 with LF line ends) in one
    step; failures are a ``UserError``."""
    target = Path(path)
    try:
        fd, temp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    except OSError as exc:
        raise UserError(f"{target}: cannot write: {exc.strerror or exc}") from None
    try:
        if isinstance(data, bytes):
            with os.fdopen(fd, "wb") as out:
                out.write(data)
        else:
            with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as out:
                out.write(data)
        os.chmod(temp, _mode_for(target))
        os.replace(temp, target)
    except OSError as exc:
        Path(temp).unlink(missing_ok=True)
        raise UserError(f"{target}: cannot write: {exc.strerror or exc}") from None


def _mode_for(target: Path) -> int:
    """Keep a replaced file's permissions; a new file gets what the umask allows.

    (The temporary file itself is private, 0600, until it is complete.)
    """
    try:
        return target.stat().st_mode & 0o7777
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask
