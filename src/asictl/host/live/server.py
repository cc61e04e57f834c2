"""The live board's server: the socket, its connections and sessions, and the loop that
keeps master time with the wall clock while nobody asks.

Everything runs on one asyncio loop, so requests are handled one at a time: a request is
never interleaved with another client's, nor with the Modbus gateway's telegrams when one
is attached (``run_live``'s ``attach``). What keeps one client from holding up the others:

- a request does at most what the protocol allows (requests.py), and the server turns to
  the other clients after each one;
- only the owner's processes are served (the peer's user, ``SO_PEERCRED``);
- at most ``max_connections`` connections at once; a further one waits its turn (in
  order of arrival, up to ``WAITING_PER_SLOT`` times as many) for at most
  ``admit_wait`` seconds, then hears the board is busy (exit 1: try again); one beyond
  the waiting places hears it at once, so a flood costs a bounded number of descriptors;
- a slot is kept for the owner's commands: while one waits, the connection silent
  longest (no request for ``EVICT_AFTER_S``, no session, not inside a request) is
  closed to make room, and any connection silent for ``idle_timeout`` is closed; each
  is told why (its command prints it), so idle connections never lock the board away;
- each such condition is logged as one line (then at most once a minute), never once
  per event;
- a session (a command's hold on the board) whose client sends nothing for
  ``session_timeout`` seconds (a stopped or hung command) is ended: the clients waiting
  for it are told of the limit, and the silent client hears why when it speaks again.

A change of the board's non-volatile state is saved before the request that made it is
answered (saver.py), and the socket, state folder and lock are put back if removed while
the board is served (guard.py).
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import time
from collections import deque
from collections.abc import Awaitable, Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from asictl.board.board import Pc2Board
from asictl.errors import ExitCode, UserError
from asictl.host.background import NotStarted, in_thread
from asictl.host.condition_log import ConditionLog
from asictl.host.emulated.boards import emulated_board, lock_file, state_file
from asictl.host.emulated.locking import note_holder
from asictl.host.event_loop import run_serving
from asictl.host.live import requests
from asictl.host.live.board import LiveBoard
from asictl.host.live.client import refuse_if_served
from asictl.host.live.guard import WATCH_S, Identity, StatePlace
from asictl.host.live.guard import identity as file_identity
from asictl.host.live.limits import (
    DEFAULT_ADMIT_WAIT_S,
    DEFAULT_IDLE_TIMEOUT_S,
    DEFAULT_MAX_CONNECTIONS,
    DEFAULT_SESSION_TIMEOUT_S,
)
from asictl.host.live.protocol import (
    JSON,
    MAX_REQUEST,
    ProtocolError,
    encode,
    peer_uid,
    read_message,
    socket_path,
)
from asictl.host.live.saver import SAVE_INTERVAL_S, NotSaved, StateKeeper
from asictl.host.transports.ports import port_name

#: How often master time catches up with the wall clock while nobody asks.
PACING_S = 0.01
#: Connections that may wait for a slot, per slot; one more hears "busy" at once.
WAITING_PER_SLOT = 4
#: A connection silent this long (and holding no session) makes way for one waiting.
EVICT_AFTER_S = 1.0


@dataclass(eq=False)
class _Connection:
    """One client: its INDEX/PAGE pointer, what it said it is, when it last asked."""

    who: str = "a client"
    pointer: requests.Pointer = field(default_factory=requests.Pointer)
    writer: asyncio.StreamWriter | None = field(default=None, repr=False)
    last: float = field(default_factory=time.monotonic)
    #: why its session was ended, said at its next request
    ended: str | None = None
    #: inside a request (a wait in master time may take a while): never silent then
    busy: bool = False


class LiveServer:
    """The socket in front of a ``LiveBoard``; everything runs on one asyncio loop."""

    def __init__(
        self, live: LiveBoard, path: Path, *, identity: dict[str, JSON] | None = None,
        on_tick: Callable[[], None] | None = None, keeper: StateKeeper | None = None,
        on_watch: Callable[[], None] | None = None,
        max_connections: int = DEFAULT_MAX_CONNECTIONS,
        session_timeout: float | None = DEFAULT_SESSION_TIMEOUT_S,
        idle_timeout: float | None = DEFAULT_IDLE_TIMEOUT_S,
        admit_wait: float = DEFAULT_ADMIT_WAIT_S,
        log: Callable[[str], None] | None = None,
    ) -> None:
        self.live = live
        live.in_session = lambda: self._owner is not None
        self.path = path
        self.identity = identity or {}
        self.on_tick = on_tick
        #: saves every change before it is acknowledged
        self.keeper = keeper
        #: called every ``WATCH_S`` (the state folder's guard); raising ends the serving
        self.on_watch = on_watch
        self.max_connections = max_connections
        self.session_timeout = session_timeout or None
        self.idle_timeout = idle_timeout or None
        self.admit_wait = admit_wait
        self.conditions = ConditionLog(log or (lambda message: None))
        self._owner: _Connection | None = None
        self._free: asyncio.Condition | None = None
        self._stop: asyncio.Event | None = None
        self._clients: set[_Connection] = set()
        #: connections waiting for a slot, in order of arrival
        self._waiting: deque[tuple[_Connection, asyncio.Future[None]]] = deque()
        self._socket_id: Identity = None

    @property
    def connections(self) -> int:
        return len(self._clients)

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

    async def _end_silent_session(self) -> None:
        owner, limit = self._owner, self.session_timeout
        if owner is None or limit is None or owner.busy or time.monotonic() - owner.last < limit:
            return
        owner.ended = (
            f"the live board ended this command's session: it sent nothing for {limit:g} s "
            "(was it stopped?), and other clients were let in; run it again"
        )
        self.conditions.event(
            "session", f"ended the session of {owner.who}: no request for {limit:g} s"
        )
        await self._release(owner)

    async def _handle(self, conn: _Connection, request: JSON) -> JSON:
        op = request.get("op") if isinstance(request, dict) else None
        if conn.ended is not None:
            raise UserError(conn.ended, ExitCode.FAILED)
        if op == "hello":
            return {"ok": True, "server": self.identity}
        if op == "begin":
            conn.who = str(request.get("who", conn.who))
            if self._owner not in (None, conn) and conn.writer is not None:
                conn.writer.write(encode({
                    "waiting": self._owner.who if self._owner else "",
                    "idle_limit": self.session_timeout,
                }))
                await conn.writer.drain()
            await self._session(conn, take=True)
            conn.last = time.monotonic()
            return {"ok": True, "server": self.identity}
        if op == "end":
            await self._release(conn)
            return {"ok": True}
        if op == "changes":
            return self._changes(request.get("since"))
        await self._session(conn)
        self.live.sync()
        if op == "io":
            answer = {"ok": True, "reads": requests.io(
                self.live, conn.pointer, request.get("ops"), conn.who)}
        elif op == "action":
            attached = requests.attached_action(self.live, request)
            result = await attached if attached is not None else requests.action(
                self.live, request, conn.who
            )
            answer = {"ok": True, "result": result}
        else:
            raise ProtocolError(f"unknown request {op!r}")
        if self.keeper is not None:
            try:
                self.keeper.save_changes()  # before the client hears it is done
            except NotSaved as exc:
                raise NotSaved(
                    f"the live board made the change but cannot save it ({exc}): it is "
                    "lost if the board stops before a save succeeds"
                ) from None
        return answer

    def _changes(self, since: JSON) -> JSON:
        """The changes after ``since`` (none for a client that has seen none yet, or
        numbers of a server before this one: it starts from now), and the number to ask
        from next."""
        log = self.live.changes
        after = log.serial
        if isinstance(since, int) and not isinstance(since, bool):
            after = min(since, after)
        return {"ok": True, "changes": [c.to_json() for c in log.since(after)],
                "next": log.serial}

    async def _client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        conn = _Connection(writer=writer)
        if not self._stranger_refused(writer) and await self._admit(conn):
            await self._converse(conn, reader, writer)
        else:
            writer.close()

    async def _converse(
        self, conn: _Connection, reader: asyncio.StreamReader, writer: asyncio.StreamWriter
    ) -> None:
        """Answer ``conn``'s requests until it leaves (or is closed: silent, or broke the
        framing); ``conn`` has its slot."""
        try:
            while True:
                request = await read_message(reader, limit=MAX_REQUEST)
                if request is None:
                    break
                ended, conn.busy = conn.ended, True
                try:
                    answer = await self._handle(conn, request)
                except UserError as exc:
                    answer = {"ok": False, "error": str(exc), "exit": int(exc.exit_code)}
                except ValueError as exc:  # the board refused a register access
                    answer = {"ok": False, "error": str(exc), "exit": int(ExitCode.FAILED)}
                finally:
                    conn.busy, conn.last = False, time.monotonic()
                writer.write(encode(answer))
                await writer.drain()
                if ended is not None:
                    break
                await asyncio.sleep(0)  # the other clients' turn
        except (OSError, asyncio.CancelledError):
            pass
        finally:
            self._leave(conn)
            await self._release(conn)
            writer.close()

    def _stranger_refused(self, writer: asyncio.StreamWriter) -> bool:
        """Only the owner's processes are served: another user's is told so."""
        uid = peer_uid(writer.get_extra_info("socket"))
        if uid is None or uid == os.geteuid():
            return False
        self.conditions.event(
            "stranger", f"refused a connection of another user (uid {uid}): the live "
            "board serves its owner only",
        )
        writer.write(encode({
            "ok": False, "exit": int(ExitCode.FAILED),
            "error": "this live board serves only the user who runs it",
        }))
        return True

    async def _admit(self, conn: _Connection) -> bool:
        """A slot for ``conn``: at once if one is free and nobody waits, else after its
        turn in line (at most ``admit_wait`` seconds); False: it was told the board is
        busy."""
        if len(self._clients) < self.max_connections and not self._waiting:
            self._clients.add(conn)
            return True
        if len(self._waiting) >= self.max_connections * WAITING_PER_SLOT:
            self.conditions.event(
                "limit", f"{self.max_connections} clients connected (--max-connections) "
                f"and {len(self._waiting)} waiting: telling further ones the board is busy",
            )
            return self._busy(conn)
        turn: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self._waiting.append((conn, turn))
        try:
            await asyncio.wait_for(turn, self.admit_wait)
        except TimeoutError:
            self.conditions.event(
                "busy", f"{self.max_connections} clients connected (--max-connections): "
                f"told clients that waited {self.admit_wait:g} s the board is busy",
            )
            return self._busy(conn)
        finally:
            with contextlib.suppress(ValueError):
                self._waiting.remove((conn, turn))
        return True

    def _busy(self, conn: _Connection) -> bool:
        assert conn.writer is not None
        conn.writer.write(encode({
            "ok": False, "exit": int(ExitCode.FAILED),
            "error": f"the live board is busy: {self.max_connections} clients are "
            "connected (serve --max-connections) and others wait their turn; try again",
        }))
        return False

    def _leave(self, conn: _Connection) -> None:
        """``conn``'s slot goes to the first connection waiting that still waits."""
        if conn not in self._clients:
            return
        self._clients.discard(conn)
        while self._waiting:
            waiting, turn = self._waiting.popleft()
            if not turn.done():
                self._clients.add(waiting)
                waiting.last = time.monotonic()  # its silence counts from now
                turn.set_result(None)
                return

    def _close_silent(self) -> None:
        """Close connections silent for ``idle_timeout``, and while others wait for a
        slot, those silent longest (``EVICT_AFTER_S``, holding no session) to make room:
        each hears why before it is closed."""
        now = time.monotonic()
        silent = sorted(
            (conn for conn in self._clients
             if not conn.busy and conn.ended is None and conn.writer is not None),
            key=lambda conn: conn.last,
        )
        room = sum(1 for _, turn in self._waiting if not turn.done())
        for conn in silent:
            quiet = now - conn.last
            if self.idle_timeout is not None and quiet >= self.idle_timeout:
                self.conditions.event(
                    "idle", f"closing connections silent for {self.idle_timeout:g} s "
                    "(--idle-timeout)",
                )
                self._close(conn, f"it sent nothing for {self.idle_timeout:g} s")
            elif room > 0 and quiet >= EVICT_AFTER_S and conn is not self._owner:
                room -= 1
                self.conditions.event(
                    "evict", f"{self.max_connections} clients connected (--max-connections)"
                    " and others waiting: closing the one silent longest for each",
                )
                self._close(conn, f"it sent nothing for {quiet:.0f} s while other "
                            "clients waited for a place")

    def _close(self, conn: _Connection, why: str) -> None:
        conn.ended = f"the live board closed this connection: {why}; run the command again"
        assert conn.writer is not None
        conn.writer.write(encode({"ok": False, "error": conn.ended, "exit": int(ExitCode.FAILED)}))
        conn.writer.close()

    # ------------------------------------------------------------------ running

    async def _listen(self) -> asyncio.AbstractServer:
        """The socket, made anew (0600, never briefly open to others)."""
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()  # ours: the caller holds the board's lock
        old = os.umask(0o177)
        try:
            server = await asyncio.start_unix_server(self._client, path=str(self.path))
        finally:
            os.umask(old)
        self._socket_id = file_identity(self.path)
        return server

    async def _watch(self, server: asyncio.AbstractServer) -> asyncio.AbstractServer:
        """The state folder's guard, then the socket: one removed is bound again."""
        if self.on_watch is not None:
            self.on_watch()
        if file_identity(self.path) == self._socket_id:
            return server
        server.close()
        server = await self._listen()
        self.conditions.event("socket", f"the live board's socket {self.path} was removed "
                              "or replaced: it is bound again")
        return server

    async def serve(self, started: Callable[[], None] | None = None) -> None:
        """Listen until ``stop()``; master time catches up every ``PACING_S``."""
        self._free, self._stop = asyncio.Condition(), asyncio.Event()
        asyncio.get_running_loop().set_exception_handler(self.conditions.loop_handler("live board"))
        server = await self._listen()
        try:
            if started is not None:
                started()
            watched = time.monotonic()
            while not self._stop.is_set():
                self.live.sync()
                if self.on_tick is not None:
                    self.on_tick()
                await self._end_silent_session()
                self._close_silent()
                if time.monotonic() - watched >= WATCH_S:
                    watched = time.monotonic()
                    server = await self._watch(server)
                with contextlib.suppress(asyncio.TimeoutError):
                    await asyncio.wait_for(self._stop.wait(), PACING_S)
        finally:
            server.close()
            if file_identity(self.path) == self._socket_id:  # never another's socket
                with contextlib.suppress(FileNotFoundError):
                    self.path.unlink()
            for conn in [*self._clients, *(waiting for waiting, _ in self._waiting)]:
                if conn.writer is not None:
                    conn.writer.close()
            await server.wait_closed()

    def stop(self) -> None:
        if self._stop is not None:
            self._stop.set()


Attachment = Callable[[LiveBoard], tuple[Awaitable[None], Callable[[], None]]]


def together(*attachments: Attachment) -> Attachment:
    """Several servers attached to one live board (the debug socket and an OPC UA
    server; the gateway and an OPC UA server): run together, stopped together."""

    def attach(live: LiveBoard) -> tuple[Awaitable[None], Callable[[], None]]:
        started = [attachment(live) for attachment in attachments]

        async def serving() -> None:
            tasks = [asyncio.ensure_future(coroutine) for coroutine, _ in started]
            for task in tasks:  # one that fails stops the others
                task.add_done_callback(
                    lambda done: stop() if not done.cancelled() and done.exception() else None
                )
            results = await asyncio.gather(*tasks, return_exceptions=True)
            for result in results:
                if isinstance(result, BaseException):
                    raise result

        def stop() -> None:
            for _, stop_one in started:
                stop_one()

        return serving(), stop

    return attach


def _server(
    board: Pc2Board, directory: Path, base: int, identity: dict[str, JSON], *,
    interval: float = SAVE_INTERVAL_S, notify: Callable[[str], None] | None = None,
    **options: Any,
) -> LiveServer:
    """The live server of ``board``: at its socket, naming this process, saving every
    change of the board's state before acknowledging it (and what changes by itself
    every ``interval`` seconds); ``options`` go to ``LiveServer``."""
    keeper = StateKeeper(board, state_file(directory, base), interval=interval, notify=notify)
    live = LiveBoard(board)
    live.save_changes = keeper.saved
    return LiveServer(
        live, socket_path(directory, base),
        identity={**identity, "pid": os.getpid()}, on_tick=keeper.tick, keeper=keeper,
        log=notify, **options,
    )


def run_live(
    base: int, directory: Path, *, identity: dict[str, JSON],
    started: Callable[[Path], None] | None = None, attach: Attachment | None = None,
    wait: bool = False, notify: Callable[[str], None] | None = None,
    save_interval: float = SAVE_INTERVAL_S, max_connections: int = DEFAULT_MAX_CONNECTIONS,
    session_timeout: float | None = DEFAULT_SESSION_TIMEOUT_S,
    idle_timeout: float | None = DEFAULT_IDLE_TIMEOUT_S,
) -> None:
    """Serve the board at ``base`` live until SIGINT/SIGTERM, holding its lock throughout.

    ``attach`` adds another server on the same loop (the Modbus gateway): it gets the live
    board and returns its coroutine and its stop function. The board's state is saved at
    the start, after every request that changed it (before the answer), every
    ``save_interval`` seconds if it changed by itself (a failed save is logged and tried
    again), and when serving ends: a final save that fails is a ``NotSaved`` saying what
    is lost. A board another process holds stops this with the holder named
    (``LockBusy``), or is waited for with ``wait``.
    """
    import signal

    refuse_if_served(directory, base)
    path = socket_path(directory, base)
    name = f"board {port_name(base)}"
    with emulated_board(base, directory, wait=wait, notify=notify, save=False) as board:
        note = f"it keeps the board running live: commands reach it through {path}"
        note_holder(lock_file(directory, base), note)
        server = _server(
            board, directory, base, identity, interval=save_interval, notify=notify,
            max_connections=max_connections, session_timeout=session_timeout,
            idle_timeout=idle_timeout,
        )
        keeper = server.keeper
        assert keeper is not None
        keeper.save()  # the state file is there, and writable, before anyone is served
        place = StatePlace(directory, base, keeper, note, notify)
        server.on_watch = place.check
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

            # whatever ends the live server (a signal, its state folder taken over)
            # ends the servers attached to it too
            serving = asyncio.ensure_future(server.serve(on_started))
            serving.add_done_callback(lambda _: stop_all())
            attached = [asyncio.ensure_future(task) for task in tasks]
            for task in attached:  # an attached server that fails ends the others too
                task.add_done_callback(
                    lambda done: stop_all() if not done.cancelled() and done.exception() else None
                )
            results = await asyncio.gather(serving, *attached, return_exceptions=True)
            for result in results:
                if isinstance(result, BaseException):
                    stop_all()
                    raise result

        try:
            run_serving(main())
        except OSError as exc:
            raise UserError(f"cannot serve: {exc.strerror or exc}") from None
        finally:
            try:
                keeper.final(name)
            finally:
                place.close()


@contextmanager
def background_live(
    base: int, directory: Path, *, identity: dict[str, JSON], timeout: float = 30.0,
    **options: Any,
) -> Iterator[Path]:
    """The board at ``base`` served live from a thread of this process until the block
    ends (the monitor does this when no ``asictl serve`` runs); its socket path.
    ``options`` go to ``LiveServer``.

    Its place in the state folder is guarded as ``run_live`` guards it: should another
    board take it meanwhile, this server stops (its socket goes, which is how its user,
    the monitor, learns of it) and leaves that board alone."""
    refuse_if_served(directory, base)
    path = socket_path(directory, base)
    name = f"board {port_name(base)}"

    @contextmanager
    def make() -> Iterator[LiveServer]:
        with emulated_board(base, directory, save=False) as board:
            note = f"it keeps the board running live: commands reach it through {path}"
            note_holder(lock_file(directory, base), note)
            server = _server(board, directory, base, identity, **options)
            keeper = server.keeper
            assert keeper is not None
            keeper.save()
            place = StatePlace(directory, base, keeper, note)
            server.on_watch = place.check
            try:
                yield server
            finally:
                try:
                    keeper.final(name)
                finally:
                    place.close()

    def serve(server: LiveServer, ready: Callable[[], None]) -> Awaitable[None]:
        return server.serve(ready)

    try:
        with in_thread("asictl-live", make, serve, timeout):
            yield path
    except NotStarted as exc:
        raise UserError(f"cannot serve board {port_name(base)}: {exc}") from None
