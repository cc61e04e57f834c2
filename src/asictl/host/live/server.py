"""The live board's server: the socket, its connections and sessions, and the loop that
keeps master time with the wall clock while nobody asks.

Everything runs on one asyncio loop, so requests are handled one at a time: a request is
never interleaved with another client's, nor with the Modbus gateway's telegrams when one
is attached (``run_live``'s ``attach``).
"""

from __future__ import annotations

import asyncio
import contextlib
import os
from collections.abc import Awaitable, Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from asictl.board.board import Pc2Board
from asictl.errors import ExitCode, UserError
from asictl.host.background import NotStarted, in_thread
from asictl.host.boards import emulated_board, lock_file, port_name, state_file
from asictl.host.live import requests
from asictl.host.live.board import LiveBoard
from asictl.host.live.client import refuse_if_served
from asictl.host.live.protocol import (
    JSON,
    ProtocolError,
    encode,
    read_message,
    socket_path,
)
from asictl.host.live.saver import SAVE_INTERVAL_S, state_saver
from asictl.host.locking import note_holder

#: How often master time catches up with the wall clock while nobody asks.
PACING_S = 0.01


@dataclass(eq=False)
class _Connection:
    """One client: its INDEX/PAGE pointer, and what it said it is."""

    who: str = "a client"
    pointer: requests.Pointer = field(default_factory=requests.Pointer)
    writer: asyncio.StreamWriter | None = field(default=None, repr=False)


class LiveServer:
    """The socket in front of a ``LiveBoard``; everything runs on one asyncio loop."""

    def __init__(
        self, live: LiveBoard, path: Path, *, identity: dict[str, JSON] | None = None,
        on_tick: Callable[[], None] | None = None,
    ) -> None:
        self.live = live
        self.path = path
        self.identity = identity or {}
        self.on_tick = on_tick
        self._owner: _Connection | None = None
        self._free: asyncio.Condition | None = None
        self._stop: asyncio.Event | None = None
        self.connections = 0

    # ------------------------------------------------------------------ sessions

    async def _session(self, conn: _Connection, *, take: bool = False) -> None:
        """Wait until no other connection has a session (and take it, with ``take``)."""
        assert self._free is not None
        async with self._free:
            await self._free.wait_for(lambda: self._owner in (None, conn))
            if take:
                self._owner = conn

    async def _release(self, conn: _Connection) -> None:
        assert self._free is not None
        async with self._free:
            if self._owner is conn:
                self._owner = None
                self._free.notify_all()

    async def _handle(self, conn: _Connection, request: JSON) -> JSON:
        op = request.get("op") if isinstance(request, dict) else None
        if op == "hello":
            return {"ok": True, "server": self.identity}
        if op == "begin":
            conn.who = str(request.get("who", conn.who))
            if self._owner not in (None, conn) and conn.writer is not None:
                conn.writer.write(encode({"waiting": self._owner.who if self._owner else ""}))
                await conn.writer.drain()
            await self._session(conn, take=True)
            return {"ok": True, "server": self.identity}
        if op == "end":
            await self._release(conn)
            return {"ok": True}
        await self._session(conn)
        self.live.sync()
        if op == "io":
            return {"ok": True, "reads": requests.io(self.live, conn.pointer, request.get("ops"))}
        if op == "action":
            attached = requests.attached_action(self.live, request)
            if attached is not None:
                return {"ok": True, "result": await attached}
            return {"ok": True, "result": requests.action(self.live, request)}
        raise ProtocolError(f"unknown request {op!r}")

    async def _client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        conn = _Connection(writer=writer)
        self.connections += 1
        try:
            while True:
                request = await read_message(reader)
                if request is None:
                    break
                try:
                    answer = await self._handle(conn, request)
                except UserError as exc:
                    answer = {"ok": False, "error": str(exc), "exit": int(exc.exit_code)}
                except ValueError as exc:  # the board refused a register access
                    answer = {"ok": False, "error": str(exc), "exit": int(ExitCode.FAILED)}
                writer.write(encode(answer))
                await writer.drain()
        except (ConnectionError, asyncio.CancelledError):
            pass
        finally:
            self.connections -= 1
            await self._release(conn)
            writer.close()

    # ------------------------------------------------------------------ running

    async def serve(self, started: Callable[[], None] | None = None) -> None:
        """Listen until ``stop()``; master time catches up every ``PACING_S``."""
        self._free, self._stop = asyncio.Condition(), asyncio.Event()
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()  # ours: the caller holds the board's lock
        old = os.umask(0o177)  # the socket is created 0600, never briefly open to others
        try:
            server = await asyncio.start_unix_server(self._client, path=str(self.path))
        finally:
            os.umask(old)
        try:
            if started is not None:
                started()
            while not self._stop.is_set():
                self.live.sync()
                if self.on_tick is not None:
                    self.on_tick()
                with contextlib.suppress(asyncio.TimeoutError):
                    await asyncio.wait_for(self._stop.wait(), PACING_S)
        finally:
            server.close()
            with contextlib.suppress(FileNotFoundError):
                self.path.unlink()
            await server.wait_closed()

    def stop(self) -> None:
        if self._stop is not None:
            self._stop.set()


Attachment = Callable[[LiveBoard], tuple[Awaitable[None], Callable[[], None]]]


def _server(
    board: Pc2Board, directory: Path, base: int, identity: dict[str, JSON], *,
    interval: float = SAVE_INTERVAL_S, notify: Callable[[str], None] | None = None,
) -> LiveServer:
    """The live server of ``board``: at its socket, naming this process, saving the
    board's state every ``interval`` seconds."""
    return LiveServer(
        LiveBoard(board), socket_path(directory, base),
        identity={**identity, "pid": os.getpid()},
        on_tick=state_saver(board, state_file(directory, base), interval=interval, notify=notify),
    )


def run_live(
    base: int, directory: Path, *, identity: dict[str, JSON],
    started: Callable[[Path], None] | None = None, attach: Attachment | None = None,
    wait: bool = False, notify: Callable[[str], None] | None = None,
    save_interval: float = SAVE_INTERVAL_S,
) -> None:
    """Serve the board at ``base`` live until SIGINT/SIGTERM, holding its lock throughout.

    ``attach`` adds another server on the same loop (the Modbus gateway): it gets the live
    board and returns its coroutine and its stop function. The board's state is saved
    every ``save_interval`` seconds (a failed save is logged and tried again) and when
    serving ends. A board another process holds stops
    this with the holder named (``LockBusy``), or is waited for with ``wait``.
    """
    import signal

    refuse_if_served(directory, base)
    path = socket_path(directory, base)
    with emulated_board(base, directory, wait=wait, notify=notify) as board:
        note_holder(
            lock_file(directory, base),
            f"it keeps the board running live: commands reach it through {path}",
        )
        server = _server(
            board, directory, base, identity, interval=save_interval, notify=notify
        )
        live = server.live

        async def main() -> None:
            stops = [server.stop]
            tasks: list[Awaitable[None]] = []
            if attach is not None:
                coroutine, stop = attach(live)
                tasks.append(coroutine)
                stops.append(stop)

            def stop_all() -> None:
                for stop in stops:
                    stop()

            loop = asyncio.get_running_loop()
            for number in (signal.SIGINT, signal.SIGTERM):
                loop.add_signal_handler(number, stop_all)

            def on_started() -> None:
                if started is not None:
                    started(path)

            results = await asyncio.gather(
                server.serve(on_started), *tasks, return_exceptions=True
            )
            for result in results:
                if isinstance(result, BaseException):
                    stop_all()
                    raise result

        try:
            asyncio.run(main())
        except OSError as exc:
            raise UserError(f"cannot serve: {exc.strerror or exc}") from None


@contextmanager
def background_live(
    base: int, directory: Path, *, identity: dict[str, JSON], timeout: float = 30.0
) -> Iterator[Path]:
    """The board at ``base`` served live from a thread of this process until the block
    ends (the monitor does this when no ``asictl serve`` runs); its socket path."""
    refuse_if_served(directory, base)
    path = socket_path(directory, base)

    @contextmanager
    def make() -> Iterator[LiveServer]:
        with emulated_board(base, directory) as board:
            yield _server(board, directory, base, identity)

    def serve(server: LiveServer, ready: Callable[[], None]) -> Awaitable[None]:
        return server.serve(ready)

    try:
        with in_thread("asictl-live", make, serve, timeout):
            yield path
    except NotStarted as exc:
        raise UserError(f"cannot serve board {port_name(base)}: {exc}") from None
