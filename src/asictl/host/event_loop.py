"""The event loop every server of asictl runs on (the live board's socket, the debug
socket, the Modbus gateway, OPC UA, the web page): asyncio's, patient when the process is
out of descriptors.

When ``accept()`` fails for want of descriptors (EMFILE, ENFILE, ENOBUFS, ENOMEM),
asyncio stops watching the listening socket for a second and then tries again, which is
the back-off wanted, but it first goes on trying the same accept up to ``backlog`` (100)
times, each failure reported and each scheduling a retry of its own: some hundred failed
calls a second per socket, and as many events for the log to count. Here each readiness
of a listening socket accepts one connection, so a failure is one call, reported once,
with one retry a second later; the connections already open are served meanwhile, and
accepting resumes by itself once descriptors are free. (A socket ready again is
reported at the loop's next turn, so a burst of connections is still accepted at once.)
"""

from __future__ import annotations

import asyncio
from collections.abc import Coroutine
from typing import Any, TypeVar

T = TypeVar("T")


class ServingLoop(asyncio.SelectorEventLoop):
    """asyncio's selector loop, accepting one connection per readiness of a listening
    socket (the one place that changes)."""

    def _accept_connection(
        self, protocol_factory: Any, sock: Any, sslcontext: Any = None, server: Any = None,
        backlog: int = 100, *rest: Any,
    ) -> None:
        super()._accept_connection(  # type: ignore[misc]
            protocol_factory, sock, sslcontext, server, 1, *rest
        )


def run_serving(coroutine: Coroutine[Any, Any, T]) -> T:
    """``asyncio.run`` on a ``ServingLoop``."""
    with asyncio.Runner(loop_factory=ServingLoop) as runner:
        return runner.run(coroutine)
