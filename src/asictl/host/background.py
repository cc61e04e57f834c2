"""An asyncio server on a thread of the calling process.

The monitor serves its own live board when no ``asictl serve`` runs, and tests and
embedders run the Modbus gateway beside their own code: both need the server started
before the caller goes on, a failure to start raised in the caller's thread, and the
server stopped from there when the block ends.
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Awaitable, Callable, Iterator
from contextlib import AbstractContextManager, contextmanager, suppress
from typing import Protocol, TypeVar

from asictl.host.event_loop import run_serving


class Stoppable(Protocol):
    def stop(self) -> None: ...


Server = TypeVar("Server", bound=Stoppable)


class NotStarted(Exception):
    """The server raised before it was ready, or was not ready in time."""


@contextmanager
def in_thread(
    name: str,
    make: Callable[[], AbstractContextManager[Server]],
    serve: Callable[[Server, Callable[[], None]], Awaitable[None]],
    timeout: float,
) -> Iterator[tuple[Server, asyncio.AbstractEventLoop]]:
    """Run ``serve(server, ready)`` on its own event loop in a daemon thread, the server
    made by ``make`` in that thread (what it opens is closed there too); yield the
    server and its loop once it has called ``ready``; stop it when the block ends."""
    ready = threading.Event()
    errors: list[BaseException] = []
    started: list[tuple[Server, asyncio.AbstractEventLoop]] = []

    def main() -> None:
        try:
            with make() as server:

                async def run() -> None:
                    started.append((server, asyncio.get_running_loop()))
                    await serve(server, ready.set)

                run_serving(run())
        except BaseException as exc:  # reported to the caller's thread
            errors.append(exc)
            ready.set()

    thread = threading.Thread(target=main, name=name, daemon=True)
    thread.start()
    if not ready.wait(timeout) or errors:
        if started and not errors:  # running but never ready: not left behind
            server, loop = started[0]
            loop.call_soon_threadsafe(server.stop)
        raise NotStarted(errors[0] if errors else "time-out")
    server, loop = started[0]
    try:
        yield server, loop
    finally:
        if thread.is_alive():  # a server that stopped by itself has closed its loop
            with suppress(RuntimeError):  # ... or is closing it just now
                loop.call_soon_threadsafe(server.stop)
        thread.join(timeout)
