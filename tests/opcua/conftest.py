"""The servers these tests start load asyncua's standard address space from the cache
(``asictl.opcua.standard_space``), built once for the whole run."""

from __future__ import annotations

import asyncio
import fcntl
import os
from pathlib import Path

import pytest
from opcua_space import standard_server

from asictl.opcua.standard_space import cache_file


@pytest.fixture(scope="session")
def _shared_caches(_shared_caches: list[Path],
                   tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """The grammars, and the standard address space's cache file, built by the first
    worker that needs it while the others wait: without it each server a test starts
    builds the space anew (1.2 s of CPU). The tests of the cache itself name a cache
    folder of their own."""
    base = tmp_path_factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    home = shared / "opcua-cache"
    home.mkdir(exist_ok=True)
    with (shared / "opcua-cache.lock").open("w") as lock, \
            pytest.MonkeyPatch.context() as patch:
        fcntl.flock(lock, fcntl.LOCK_EX)
        patch.setenv("XDG_CACHE_HOME", str(home))
        path = cache_file()
        assert path is not None
        if not path.is_file():
            asyncio.run(standard_server())
        assert path.is_file()
    return [*_shared_caches, path]
