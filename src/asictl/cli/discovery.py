"""Which files a folder stands for: ``asictl check DIR`` (and ``fmt DIR``) work on a
project's programs, not its version control, virtual environments and build outputs.

A folder is walked for ``*.asi`` files (``fmt``: also ``*.fb``); folders whose name
starts with a dot (``.git``, ``.venv``, ``.tox``...) and the usual build outputs are not
entered, and ``--exclude`` globs leave out more. A folder named on the command line is
walked even if it is hidden: the user asked for it.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from fnmatch import fnmatch
from pathlib import Path, PurePath

from asictl.errors import UserError

#: Folders never entered (besides every folder whose name starts with a dot).
SKIPPED_FOLDERS = frozenset({"build", "dist", "__pycache__", "node_modules"})
PROGRAM_SUFFIX = ".asi"
BLOCK_SUFFIX = ".fb"


def skipped_folder(name: str) -> bool:
    return name.startswith(".") or name in SKIPPED_FOLDERS


def excluded(path: PurePath, patterns: Sequence[str]) -> bool:
    """Whether a --exclude glob matches the path (as relative to the folder walked, or as
    given) or its name: ``old``, ``vendor/*``, ``*_draft.asi`` all work."""
    text = path.as_posix()
    return any(fnmatch(text, p) or fnmatch(path.name, p) for p in patterns)


def programs_in(
    folder: Path, exclude: Sequence[str] = (), suffixes: Sequence[str] = (PROGRAM_SUFFIX,)
) -> list[Path]:
    """Every file below ``folder`` with one of ``suffixes`` (any case), in a stable order."""
    found: list[Path] = []
    for parent, folders, files in os.walk(folder):
        here = Path(parent)
        relative = here.relative_to(folder)
        folders[:] = sorted(
            name for name in folders
            if not skipped_folder(name) and not excluded(relative / name, exclude)
        )
        found.extend(
            here / name for name in sorted(files)
            if name.lower().endswith(tuple(suffixes)) and not excluded(relative / name, exclude)
        )
    return found


def expand(paths: Iterable[str], exclude: Sequence[str] = ()) -> list[str]:
    """Files as given (unless excluded), each folder as the programs below it; a file
    named twice is checked once. A folder without programs is a ``UserError``."""
    files: list[str] = []
    for path in paths:
        if path != "-" and Path(path).is_dir():
            found = programs_in(Path(path), exclude)
            if not found:
                raise UserError(
                    f"{path}: no .asi files in this folder (hidden folders, build outputs "
                    "and --exclude matches are not searched)"
                )
            files.extend(str(p) for p in found)
        elif path == "-" or not excluded(PurePath(path), exclude):
            files.append(path)
    return list(dict.fromkeys(files))
