"""The web server on a live board's own loop (``host.live.run_live``'s ``attach``), beside
the board's socket as the OPC UA server is (opcua/server.py): uvicorn serves the ASGI
application (web/app.py) and a refresh reads the board every ``interval`` while a page or
script listens to the event stream, so an idle server reads nothing.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
from collections.abc import Awaitable, Callable, Iterator
from dataclasses import dataclass

import uvicorn

from asictl.errors import UserError
from asictl.host.live.board import LiveBoard
from asictl.host.transports.target import is_loopback
from asictl.web.access import Access
from asictl.web.app import create_app
from asictl.web.board import Busy, WebBoard
from asictl.web.stream import Hub

DEFAULT_PORT = 8080
#: How often the board is read for listeners (seconds): a change reaches a page within it.
DEFAULT_INTERVAL_S = 0.05


@dataclass(frozen=True)
class WebOptions:
    host: str = "127.0.0.1"
    port: int = DEFAULT_PORT
    writable: bool = False
    token: str | None = None
    interval: float = DEFAULT_INTERVAL_S
    #: programs may be downloaded (--http-download)
    downloads: bool = False

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"


class _Server(uvicorn.Server):
    """uvicorn without its signal handlers: the live board's own stop the server."""

    @contextlib.contextmanager
    def capture_signals(self) -> Iterator[None]:
        yield


def web_attachment(
    options: WebOptions, name: str, started: Callable[[str], None] | None = None,
) -> Callable[[LiveBoard], tuple[Awaitable[None], Callable[[], None]]]:
    """The web server for ``run_live``'s ``attach``; ``started(url)`` hears where it
    listens once it does."""

    def attach(live: LiveBoard) -> tuple[Awaitable[None], Callable[[], None]]:
        board, hub = WebBoard(live, name), Hub()

        def refresh() -> None:
            try:
                hub.publish(board.status())
                hub.changes(board.changes())
            except Busy:  # a command holds the board: the last reading stands
                pass
            except UserError as exc:  # a board that does not answer (in reset)
                hub.failed(exc)

        app = create_app(board, hub, Access(options.writable, options.token),
                         loopback=is_loopback(options.host), refresh=refresh,
                         downloads=options.downloads)
        config = uvicorn.Config(
            app, host=options.host, port=options.port, log_config=None, access_log=False,
            lifespan="off", log_level="warning", timeout_graceful_shutdown=1,
        )
        server = _Server(config)

        async def serve() -> None:
            logging.getLogger("uvicorn.error").setLevel(logging.CRITICAL)
            listening = _bind(options.host, options.port)
            serving = asyncio.ensure_future(server.serve(sockets=[listening]))
            while not server.started and not serving.done():
                await asyncio.sleep(0.01)
            if server.started and started is not None:
                started(WebOptions(options.host, listening.getsockname()[1]).url)
            while not serving.done():
                if hub.listeners:
                    refresh()
                await asyncio.wait([serving], timeout=options.interval)
            await serving

        def stop() -> None:
            server.should_exit = True

        return serve(), stop

    return attach


def _bind(host: str, port: int) -> socket.socket:
    """The listening socket, bound here so that a port in use is a plain error."""
    try:
        family = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0][0]
        listening = socket.socket(family, socket.SOCK_STREAM)
        listening.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listening.bind((host, port))
    except OSError as exc:
        raise UserError(f"--http {host}:{port}: cannot listen there: "
                        f"{exc.strerror or exc}") from None
    return listening
