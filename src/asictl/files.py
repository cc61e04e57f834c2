"""Writing output files: never half-written, never over an input, never over a device.

A HEX image that is cut short would still look plausible to a programmer tool, so a
regular file is written to a temporary file in its directory and renamed over the target
only when complete (a rename within one directory is atomic). A character device or a
FIFO (``-o /dev/null``, ``--csv >(sort)``) is written as a stream: replacing it by a
regular file would, run as root, turn /dev/null into a plain file. A symbolic link keeps
pointing at the file it names, which is the one replaced.

``write_output`` is what commands use: it also refuses to replace one of the command's
own inputs and writes '-' to standard output.
"""

from __future__ import annotations

import errno
import os
import stat
import sys
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TextIO

from asictl.diagnostics import printable
from asictl.errors import UserError

#: The name that means standard output.
STDOUT = "-"
#: Names that stand for standard input among a command's inputs.
_STDIN_NAMES = frozenset({"-", "<stdin>"})


def write_output(
    path: str | Path, data: str | bytes, *, inputs: Iterable[str | Path] = ()
) -> None:
    """Write a command's output: '-' to standard output, otherwise as ``write_atomic``
    does, after ``refuse_inputs``."""
    if str(path) == STDOUT:
        write_stdout(data)
        return
    refuse_inputs(path, inputs)
    write_atomic(path, data)


def write_stdout(data: str | bytes) -> None:
    """An output to standard output, all of it or a ``UserError``: a closed standard
    output (``>&-``: Python then has no ``sys.stdout``), a full disk or a reader that went
    away must not pass for a written file."""
    out = sys.stdout
    if out is None:
        raise UserError("standard output: cannot write: it is closed")
    try:
        if isinstance(data, bytes):
            out.flush()
            out.buffer.write(data)
            out.buffer.flush()
        else:
            out.write(data)
            out.flush()
    except OSError as exc:
        raise UserError(f"standard output: cannot write: {exc.strerror or exc}") from None


def cache_home() -> Path | None:
    """Where asictl's caches live, named, not made: ``$XDG_CACHE_HOME/asictl`` (a relative
    one is ignored, as the XDG base directory specification says), else
    ``~/.cache/asictl``; None without a home directory. Beside no program, so that no
    source folder fills with files of asictl's."""
    base = os.environ.get("XDG_CACHE_HOME", "")
    if not os.path.isabs(base):
        base = os.path.join(os.path.expanduser("~"), ".cache")
    if not os.path.isabs(base):  # no home directory
        return None
    return Path(base, "asictl")


def cache_directory() -> Path | None:
    """asictl's own cache directory (``cache_home``), made owner-only when new; None where
    there is none to be had, or where it is not this user's alone (owned by another, or
    writable by group or others).

    Private, never the shared temporary directory: the caches in it are pickles, and
    loading one planted by another user would run their code.
    """
    directory = cache_home()
    if directory is None:
        return None
    try:
        directory.mkdir(mode=0o700, parents=True, exist_ok=True)
        status = directory.stat()
    except OSError:
        return None
    if status.st_uid != os.getuid() or status.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return None
    return directory


def grammar_cache(name: str) -> str | bool:
    """Where lark keeps the analysed grammar ``name`` (its ``cache=``): building the IL
    grammar takes about 0.5 s and the condition language's 0.2 s, loading either 20 ms.

    asictl's private cache directory, not lark's default of the shared temporary
    directory (``cache_directory``: the cache is a pickle); False where there is none.
    lark checks the grammar, its options and both versions on loading and builds anew
    when they differ; the versions in the name keep two installations from taking turns.
    The options include this path, so a cache file is only ever good where it was built:
    one linked or copied from another folder is built again (and written through a link).
    """
    directory = cache_directory()
    if directory is None:
        return False
    import lark  # its caller has imported it: no cost, and none for those who never parse

    version = f"lark{lark.__version__}-py{sys.version_info[0]}.{sys.version_info[1]}"
    return str(directory / f"{name}-grammar-{version}.cache")


def real_path(path: str | Path) -> Path:
    """Where ``path`` leads, as far as it leads: a symbolic-link loop ends the walk there
    (``Path.resolve`` raises a RuntimeError on one), so that the write that follows
    reports it plainly ("Too many levels of symbolic links")."""
    return Path(os.path.realpath(path))


def refuse_inputs(path: str | Path, inputs: Iterable[str | Path]) -> None:
    """A ``UserError`` if ``path`` is one of ``inputs`` (by name, link or hard link)."""
    target = Path(path)
    if not _is_regular(target):
        return  # nothing there to lose, or a device or FIFO, which is written as a stream
    for source in inputs:
        if str(source) in _STDIN_NAMES:
            continue
        try:
            same = os.path.samefile(target, source)
        except OSError:
            same = False
        if same:
            raise UserError(
                f"{path}: is an input of this command ({source}); not overwritten"
            )


def write_atomic(path: str | Path, data: str | bytes, *, follow_links: bool = True) -> None:
    """Replace ``path`` with ``data`` (text is written as UTF-8 with LF line ends) in one
    step, or write it as a stream to a device or FIFO; failures are a ``UserError``.
    ``follow_links=False`` replaces a symbolic link at ``path`` itself, never what it
    names: for files whose names a program chooses in a folder others can write to."""
    write_together([(path, data)], follow_links=follow_links)


def write_together(items: Sequence[tuple[str | Path, str | bytes]], *,
                   follow_links: bool = True) -> None:
    """Write several files all or nothing: every regular file is first written in full
    to a temporary file beside it, and only when all are complete are they renamed into
    place (devices and FIFOs are written after that, as streams). A name too long, a
    full disk or a missing folder thus stops the lot before any file is touched."""
    staged: list[tuple[Path, Path, Path]] = []  # (temporary, real target, as named)
    streams: list[tuple[Path, bytes]] = []
    try:
        for path, data in items:
            target = Path(path)
            raw = data if isinstance(data, bytes) else data.encode("utf-8")
            mode = _writable_mode(target, follow_links)
            if mode is not None and not stat.S_ISREG(mode) and not stat.S_ISLNK(mode):
                streams.append((target, raw))
                continue
            real = real_path(target) if follow_links else target
            staged.append((_stage(real, raw, shown=target), real, target))
        for temp, real, shown in staged:
            try:
                os.replace(temp, real)
            except OSError as exc:
                raise UserError(f"{shown}: cannot write: {exc.strerror or exc}") from None
    finally:
        for temp, _, _ in staged:
            temp.unlink(missing_ok=True)  # gone once renamed; left over after a failure
    for target, raw in streams:
        _write_stream(target, raw)


@contextmanager
def open_atomic(path: str | Path, *, inputs: Iterable[str | Path] = ()) -> Iterator[TextIO]:
    """An output too long to hold in memory (a recording of hours), written as a stream
    and yet whole or not at all: into a temporary file beside ``path`` that is renamed
    over it when the ``with`` block ends normally, and removed when it raises. A device
    or FIFO is written to directly, as ``write_atomic`` does."""
    target = Path(path)
    refuse_inputs(target, inputs)
    mode = _writable_mode(target, follow_links=True)
    if mode is not None and not stat.S_ISREG(mode):
        try:
            with open(target, "w", encoding="utf-8", newline="\n") as stream:
                yield stream
        except OSError as exc:
            raise UserError(f"{target}: cannot write: {exc.strerror or exc}") from None
        return
    real = real_path(target)
    temp = _stage(real, b"", shown=target)
    try:
        with open(temp, "w", encoding="utf-8", newline="\n") as out:
            yield out
        os.replace(temp, real)
    except OSError as exc:
        raise UserError(f"{target}: cannot write: {exc.strerror or exc}") from None
    finally:
        temp.unlink(missing_ok=True)  # gone once renamed


def _writable_mode(target: Path, follow_links: bool) -> int | None:
    """The mode of what is at ``target`` (None: nothing), or a ``UserError`` where nothing
    can be written: a directory, or a name the system cannot look up."""
    try:
        mode = (os.stat if follow_links else os.lstat)(target).st_mode
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise UserError(f"{target}: cannot write: {exc.strerror or exc}") from None
    if stat.S_ISDIR(mode):
        raise UserError(f"{target}: cannot write: it is a directory")
    return mode


def _is_regular(path: Path) -> bool:
    try:
        return stat.S_ISREG(os.stat(path).st_mode)
    except OSError:
        return False


def _stage(target: Path, data: bytes, *, shown: Path) -> Path:
    """``data`` complete in a temporary file beside ``target``, with the target's mode.

    The temporary name keeps at most 100 characters of the target's, so that a target
    name near the file system's limit still has room for the affixes.
    """
    try:
        fd, name = tempfile.mkstemp(
            dir=target.parent, prefix=f".{target.name[:100]}.", suffix=".tmp"
        )
    except OSError as exc:
        raise UserError(f"{shown}: cannot write: {exc.strerror or exc}") from None
    temp = Path(name)
    try:
        with os.fdopen(fd, "wb") as out:
            out.write(data)
        os.chmod(temp, _mode_for(target))
    except OSError as exc:
        temp.unlink(missing_ok=True)
        raise UserError(f"{shown}: cannot write: {exc.strerror or exc}") from None
    return temp


def shown_name(name: str) -> str:
    """A file name as it can be printed safely (``printable``: a newline in it too)."""
    return printable(name, lines=False)


def _write_stream(target: Path, data: bytes) -> None:
    """Write to a device or FIFO as ``cat > target`` would, but never wait for a reader
    that is not there (opening a FIFO for writing blocks until one is)."""
    try:
        fd = os.open(target, os.O_WRONLY | os.O_NONBLOCK)
    except OSError as exc:
        reason = exc.strerror or str(exc)
        if exc.errno == errno.ENXIO:  # a FIFO nobody has open for reading
            reason = "no process reads from it"
        raise UserError(f"{target}: cannot write: {reason}") from None
    try:
        os.set_blocking(fd, True)
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view) :]
    except OSError as exc:
        raise UserError(f"{target}: cannot write: {exc.strerror or exc}") from None
    finally:
        os.close(fd)


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
