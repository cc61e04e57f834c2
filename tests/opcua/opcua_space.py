"""asyncua's standard address space built as ``serve`` builds it, for the OPC UA tests
(imported explicitly: ``from opcua_space import collector_off``)."""

from __future__ import annotations

import contextlib
import gc
from collections.abc import Iterator

from asyncua.server.server import Server

from asictl.opcua.standard_space import CachedStandardSpace


@contextlib.contextmanager
def collector_off() -> Iterator[None]:
    """As ``serve`` builds its address space (``_kept_for_good``), without freezing what
    was built for good: the collections that 650,000 new objects set off are most of the
    time of building, storing and loading them."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


async def standard_server() -> Server:
    """A server on the standard address space, loaded from the cache or built (and then
    kept there), with the collector off."""
    with collector_off():
        server = Server(iserver=CachedStandardSpace())
        await server.init()
        return server
