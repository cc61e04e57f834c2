"""The servers these tests start load asyncua's standard address space from the cache
(``asictl.opcua.standard_space``), built once for the whole run."""

from __future__ import annotations

import asyncio
import contextlib
import fcntl
import gc
import os
from pathlib import Path

import pytest


async def _build() -> None:
    from asyncua import Server

    from asictl.opcua.standard_space import CachedStandardSpace

    await Server(iserver=CachedStandardSpace()).init()


@pytest.fixture(scope="session")
def _standard_space(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The cache file, built by the first worker that needs it while the others wait:
    without it each server a test starts builds the space anew (1.2 s of CPU)."""
    base = tmp_path_factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    home = shared / "opcua-cache"
    home.mkdir(exist_ok=True)
    with (shared / "opcua-cache.lock").open("w") as lock, \
            pytest.MonkeyPatch.context() as patch:
        fcntl.flock(lock, fcntl.LOCK_EX)
        patch.setenv("XDG_CACHE_HOME", str(home))
        from asictl.opcua.standard_space import cache_file

        path = cache_file()
        assert path is not None
        if not path.is_file():
            gc.disable()  # as serve builds it: the collections are most of the time
            try:
                asyncio.run(_build())
            finally:
                gc.enable()
        assert path.is_file()
    return path


@pytest.fixture(autouse=True)
def _standard_space_cached(_standard_space: Path) -> None:
    """A link to it in the test's own cache folder (tests/conftest.py); the tests of the
    cache itself name a cache folder of their own."""
    home = Path(os.environ["XDG_CACHE_HOME"], "asictl")
    with contextlib.suppress(FileExistsError):
        (home / _standard_space.name).symlink_to(_standard_space)
