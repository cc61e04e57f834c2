"""asictl.host.background: a server on a thread of the calling process."""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections.abc import Callable, Iterator

import pytest

from asictl.host.background import NotStarted, in_thread


class Server:
    def __init__(self) -> None:
        self.stopped = asyncio.Event()
        self.events: list[str] = []

    async def serve(self, ready: Callable[[], None]) -> None:
        self.events.append(f"serving in {threading.current_thread().name}")
        ready()
        await self.stopped.wait()
        self.events.append("stopped")

    def stop(self) -> None:
        self.stopped.set()


def test_the_server_runs_in_its_thread_until_the_block_ends() -> None:
    made: list[str] = []

    @contextlib.contextmanager
    def make() -> Iterator[Server]:
        made.append("opened")
        yield Server()
        made.append("closed")

    with in_thread("test-server", make, Server.serve, timeout=5) as (server, loop):
        assert server.events == ["serving in test-server"]
        assert loop.is_running()
    assert server.events[-1] == "stopped"
    assert made == ["opened", "closed"]


def test_a_failure_to_start_is_raised_in_the_callers_thread() -> None:
    async def fail(server: Server, ready: Callable[[], None]) -> None:
        raise OSError("address in use")

    with (
        pytest.raises(NotStarted, match="address in use"),
        in_thread("test-server", lambda: contextlib.nullcontext(Server()), fail, 5),
    ):
        pytest.fail("the block must not run")


def test_a_server_that_never_gets_ready_times_out_and_is_stopped() -> None:
    async def never(server: Server, ready: Callable[[], None]) -> None:
        await server.stopped.wait()
        server.events.append("stopped")

    server = Server()
    with (
        pytest.raises(NotStarted, match="time-out"),
        in_thread("test-server", lambda: contextlib.nullcontext(server), never, 0.2),
    ):
        pytest.fail("the block must not run")
    deadline = time.monotonic() + 5
    while "stopped" not in server.events and time.monotonic() < deadline:
        time.sleep(0.01)
    assert server.events == ["stopped"]
