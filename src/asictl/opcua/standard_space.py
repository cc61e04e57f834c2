"""asyncua's standard address space (OPC UA's own some 6,000 nodes: the types, the Server
object) kept between starts in asictl's cache directory.

asyncua builds it at every start from generated code, which took 0.7 s of CPU of the
server's start (with the garbage collector off; 1.1 s with it); loading the nodes it
built once, as asyncua's own ``AddressSpace.dump`` pickles them, takes 0.3 s
(docs/performance.md). asyncua's ``shelf_file`` does not: it loads each node from a dbm
file when first asked for, which made the start slower still. The file is named by the
asyncua and Python versions that wrote it, and a file that does not load is built
anew and replaced; the cache directory is the user's own (files.cache_directory), since
loading a pickle planted by someone else would run their code.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from pathlib import Path

import asyncua
from asyncua.server.internal_server import InternalServer

from asictl.files import cache_directory


def cache_file() -> Path | None:
    """Where the standard address space of this asyncua and Python is kept (None: no
    cache directory)."""
    directory = cache_directory()
    if directory is None:
        return None
    python = f"{sys.version_info[0]}.{sys.version_info[1]}"
    return directory / f"opcua-standard-space-asyncua{asyncua.__version__}-py{python}.pickle"


class CachedStandardSpace(InternalServer):
    """asyncua's internal server, whose standard address space is loaded from the cache
    when there is one, and else built as asyncua builds it and then stored there."""

    async def load_standard_address_space(self, shelf_file: Path | None = None) -> None:
        path = cache_file()
        if path is not None and path.is_file():
            try:
                self.aspace.load(path)
                return
            except Exception:  # whatever a bad pickle raises: built anew
                pass
        await super().load_standard_address_space(shelf_file)
        if path is not None:
            _store(self, path)


def _store(server: InternalServer, path: Path) -> None:
    """The nodes asyncua just built, written whole under their final name or not at all:
    the cache only saves time, so a start that cannot write it (the disk full, a node
    that a later asyncua makes unpicklable) goes on without."""
    try:
        handle, name = tempfile.mkstemp(dir=path.parent, prefix=".opcua-", suffix=".tmp")
    except OSError:
        return
    os.close(handle)
    try:
        server.aspace.dump(name)
        os.replace(name, path)
    except Exception:  # whatever pickling or writing raises: not cached
        pass
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(name)
