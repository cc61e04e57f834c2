"""A live emulated board: master time follows the wall clock, and every command reaches it.

``asictl serve`` (and ``asictl gateway serve``, which puts Modbus in front of the same
board) keeps one emulated PC2 board running in real time and listens on a Unix socket in
the state directory, ``pc2-300h.sock`` (mode 0600: only its owner may talk to the board).
The other commands find the socket (``open_live``) and drive the board through it with
the very driver code a real board gets: a request carries accesses to the three I/O
registers, batched (writes wait until a read needs their effect, and a block of data
reads is one access with a count), so a download moves a 240-byte block per request.

Protocol: each message is a 4-byte big-endian length and that many bytes of UTF-8 JSON.
Requests: ``{"op": "hello"}``; ``{"op": "begin", "who": TEXT}`` / ``{"op": "end"}`` (a
session: the client has the board to itself until it ends or disconnects; a client kept
waiting first gets ``{"waiting": HOLDER}``); ``{"op": "io", "ops": [...]}`` with
``["w", OFFSET, [BYTE, ...]]`` and ``["r", OFFSET, COUNT]``, answered by ``{"ok": true,
"reads": [[BYTE, ...], ...]}``; ``{"op": "action", "name": NAME, "args": {...}}`` for the
emulated-only actions of ``host.emulated`` (the cable, the set button, the program's
timers and counters, and ``lines``: the program's IL lines with their values in the
latest cycle, for which the board runs one cycle under line hooks and removes them
again). A failure is ``{"ok": false, "error": TEXT, "exit": CODE}``.

Each connection has its own INDEX/PAGE pointer, restored before its accesses, and a
command written to the command byte runs to its acknowledge before the request returns
(the board executes it at its next AS-i cycle, a few milliseconds of master time): no
request of another client, and no Modbus telegram, can come between.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import socket
import struct
import time
from collections.abc import Awaitable, Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from asictl.board.board import Pc2Board
from asictl.errors import ExitCode, UserError
from asictl.files import write_atomic
from asictl.host.background import NotStarted, in_thread
from asictl.host.boards import emulated_board, lock_file, port_name, state_file
from asictl.host.condition_log import ConditionLog
from asictl.host.emulated import VIEWS, run_action
from asictl.host.locking import is_free, note_holder
from asictl.platform.pc2 import (
    ACK,
    COMMAND,
    COMMAND_TIMEOUT_MS,
    NAK,
    PAGE_MASK,
    PAGE_RESET_BIT,
    PAGE_SIZE,
    PORT_DATA,
    PORT_INDEX,
    PORT_PAGE,
)

#: How often master time catches up with the wall clock while nobody asks.
PACING_S = 0.01
#: Master time one catch-up may run at most (after the process was stopped, say).
MAX_CATCH_UP_MS = 1000.0
#: Master time a command may take before the request returns without its acknowledge.
COMMAND_STEP_MS = 0.25
#: The board's non-volatile state is written this often while it runs (and at the end).
SAVE_INTERVAL_S = 10.0
#: The largest message either side accepts.
MAX_MESSAGE = 1 << 20
#: How long a client waits for an answer (a session may wait longer: it is announced).
ANSWER_TIMEOUT_S = 30.0
_LENGTH = struct.Struct(">I")

JSON = Any


def socket_path(directory: Path, base: int) -> Path:
    return directory / f"pc2-{port_name(base).lower()}.sock"


def encode(message: JSON) -> bytes:
    data = json.dumps(message, separators=(",", ":")).encode()
    return _LENGTH.pack(len(data)) + data


def decode(data: bytes) -> JSON:
    return json.loads(data.decode())


async def read_message(reader: asyncio.StreamReader) -> JSON | None:
    """The next message of a client; None when it went away or broke the framing (a
    message over ``MAX_MESSAGE``, bytes that are not JSON): the connection ends."""
    try:
        (length,) = _LENGTH.unpack(await reader.readexactly(_LENGTH.size))
        if length > MAX_MESSAGE:
            return None
        return decode(await reader.readexactly(length))
    except (asyncio.IncompleteReadError, ConnectionError, ValueError):
        return None


class ProtocolError(UserError):
    """The other end broke the protocol or went away."""

    exit_code = ExitCode.FAILED


# --------------------------------------------------------------------------- the board


class Hold(Protocol):
    """What holds a live board (the debugger of ``asictl dap``'s attach): it lets master
    time pass in its own way (standing still while the program is paused), and turns
    away the emulated-only actions that would run or watch the program behind its back."""

    def advance(self, ms: float) -> None: ...

    def refusal(self, action: str) -> str | None: ...


class LiveBoard:
    """A ``Pc2Board`` whose master time follows ``clock`` (seconds, monotonic)."""

    def __init__(self, board: Pc2Board, clock: Callable[[], float] = time.monotonic) -> None:
        self.board = board
        self._clock = clock
        self._wall = clock()
        self._master = board.now_ms
        #: the debugger holding the board, if one does
        self.hold: Hold | None = None

    def advance(self, ms: float) -> None:
        """Let ``ms`` of master time pass, through the hold if there is one."""
        if self.hold is not None:
            self.hold.advance(ms)
        else:
            self.board.advance(ms)

    def rebase(self) -> None:
        """Master time goes on from here: a board that stood still (held at a breakpoint)
        does not catch up with the pause."""
        self._wall, self._master = self._clock(), self.board.now_ms

    def sync(self) -> None:
        """Let master time catch up with the wall clock; a board that ran ahead (a command
        run to its acknowledge) waits until the wall clock has caught up instead."""
        target = self._master + (self._clock() - self._wall) * 1000
        lag = target - self.board.now_ms
        if lag > MAX_CATCH_UP_MS:  # the process stood still: do not replay the pause
            self._wall, self._master = self._clock(), self.board.now_ms + MAX_CATCH_UP_MS
            lag = MAX_CATCH_UP_MS
        if lag > 0:
            self.advance(lag)

    def run_command(self) -> None:
        """Run the board until the command just written is acknowledged (or times out)."""
        board, waited = self.board, 0.0
        while board.dpram[COMMAND] not in (ACK, NAK) and waited < COMMAND_TIMEOUT_MS:
            self.advance(COMMAND_STEP_MS)
            waited += COMMAND_STEP_MS


@dataclass(eq=False)
class _Connection:
    """One client: its INDEX/PAGE pointer, and what it said it is."""

    who: str = "a client"
    pointer: int = 0
    writer: asyncio.StreamWriter | None = field(default=None, repr=False)

    def step(self) -> None:
        index = (self.pointer & 0xFF) + 1
        self.pointer = self.pointer + 1 if index < PAGE_SIZE else 0


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

    # ------------------------------------------------------------------ requests

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
            return {"ok": True, "reads": self._io(conn, request.get("ops"))}
        if op == "action":
            name, args = request.get("name"), request.get("args") or {}
            if not isinstance(name, str) or not isinstance(args, dict):
                raise ProtocolError("an action needs a name and arguments")
            refusal = self.live.hold.refusal(name) if self.live.hold is not None else None
            if refusal is not None:
                raise UserError(refusal, ExitCode.FAILED)
            return {"ok": True, "result": run_action(self.live.board, name, args)}
        raise ProtocolError(f"unknown request {op!r}")

    def _io(self, conn: _Connection, ops: JSON) -> list[list[int]]:
        """Register accesses in order, with this connection's pointer."""
        if not isinstance(ops, list):
            raise ProtocolError("'io' needs a list of accesses")
        board = self.live.board
        page_bits = PAGE_RESET_BIT if board.in_reset else 0
        board.io_write(PORT_INDEX, conn.pointer & 0xFF)
        board.io_write(PORT_PAGE, conn.pointer >> 8 | page_bits)
        reads: list[list[int]] = []
        for op in ops:
            if not (isinstance(op, list) and len(op) == 3 and op[1] in (0, 1, 2)):
                raise ProtocolError(f"malformed access {op!r}")
            kind, offset, arg = op
            if kind == "w" and isinstance(arg, list):
                for value in arg:
                    self._write(conn, offset, value)
            elif kind == "r" and isinstance(arg, int) and 0 < arg <= MAX_MESSAGE // 4:
                out = []
                for _ in range(arg):
                    out.append(board.io_read(offset))
                    if offset == PORT_DATA:
                        conn.step()
                reads.append(out)
            else:
                raise ProtocolError(f"malformed access {op!r}")
        return reads

    def _write(self, conn: _Connection, offset: int, value: JSON) -> None:
        if not isinstance(value, int) or not 0 <= value <= 0xFF:
            raise ProtocolError(f"a register takes a byte, not {value!r}")
        board = self.live.board
        board.io_write(offset, value)
        if offset == PORT_DATA:
            address = conn.pointer
            conn.step()
            if address == COMMAND and value not in (ACK, NAK):
                self.live.run_command()
        elif offset == PORT_INDEX:
            conn.pointer = conn.pointer & ~0xFF | value
        else:
            conn.pointer = (value & PAGE_MASK) << 8 | conn.pointer & 0xFF

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


def _saver(
    board: Pc2Board, path: Path, *, interval: float = SAVE_INTERVAL_S,
    notify: Callable[[str], None] | None = None,
) -> Callable[[], None]:
    """Writes the board's non-volatile state when ``interval`` seconds have passed.

    A save that fails (the state directory removed, the disk full) must not end the
    serving: it is logged (once, then at most once a minute) and tried again at the next
    interval, and a line says when a save succeeds again.
    """
    saved = [time.monotonic()]
    failing = [False]
    log = notify or (lambda message: None)
    conditions = ConditionLog(log)

    def save_now_and_then() -> None:
        if time.monotonic() - saved[0] < interval:
            return
        saved[0] = time.monotonic()
        text = json.dumps(board.nonvolatile(), indent=1, sort_keys=True)
        try:
            write_atomic(path, text + "\n")
        except UserError as exc:
            failing[0] = True
            conditions.event("save", f"cannot save the board state ({exc}); trying again "
                             f"every {interval:g} s, still serving")
            return
        if failing[0]:
            failing[0] = False
            log(f"the board state is saved again in {path}")

    return save_now_and_then


def _server(
    board: Pc2Board, directory: Path, base: int, identity: dict[str, JSON], *,
    interval: float = SAVE_INTERVAL_S, notify: Callable[[str], None] | None = None,
) -> LiveServer:
    """The live server of ``board``: at its socket, naming this process, saving the
    board's state every ``interval`` seconds."""
    return LiveServer(
        LiveBoard(board), socket_path(directory, base),
        identity={**identity, "pid": os.getpid()},
        on_tick=_saver(board, state_file(directory, base), interval=interval, notify=notify),
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


# --------------------------------------------------------------------------- the client


class LiveClient:
    """A connection to a live board; requests are answered in order."""

    def __init__(self, sock: socket.socket, path: Path) -> None:
        self.sock = sock
        self.path = path
        self.server: dict[str, JSON] = {}

    def _send(self, message: JSON) -> None:
        try:
            self.sock.sendall(encode(message))
        except OSError as exc:
            raise ProtocolError(f"{self.path}: the live board went away ({exc})") from None

    def _receive(self, timeout: float | None = ANSWER_TIMEOUT_S) -> JSON:
        self.sock.settimeout(timeout)
        try:
            head = self._exactly(_LENGTH.size)
            (length,) = _LENGTH.unpack(head)
            return decode(self._exactly(length))
        except TimeoutError:
            raise ProtocolError(f"{self.path}: the live board did not answer") from None
        except OSError as exc:
            raise ProtocolError(f"{self.path}: the live board went away ({exc})") from None

    def _exactly(self, size: int) -> bytes:
        data = b""
        while len(data) < size:
            chunk = self.sock.recv(size - len(data))
            if not chunk:
                raise ProtocolError(f"{self.path}: the live board went away")
            data += chunk
        return data

    def request(self, message: JSON) -> JSON:
        self._send(message)
        return self._answer(self._receive())

    @staticmethod
    def _answer(answer: JSON) -> JSON:
        if not isinstance(answer, dict) or not answer.get("ok"):
            error = answer.get("error", "malformed answer") if isinstance(answer, dict) else ""
            code = answer.get("exit", 1) if isinstance(answer, dict) else 1
            raise UserError(str(error), ExitCode(code) if code in (1, 2) else ExitCode.FAILED)
        return answer

    def hello(self) -> dict[str, JSON]:
        server = self.request({"op": "hello"}).get("server", {})
        self.server = server if isinstance(server, dict) else {}
        return self.server

    @contextmanager
    def session(self, who: str, waiting: Callable[[str], None] | None = None) -> Iterator[None]:
        """The board to this client alone; ``waiting`` hears who has it meanwhile."""
        self._send({"op": "begin", "who": who})
        answer = self._receive()
        if isinstance(answer, dict) and "waiting" in answer:
            if waiting is not None:
                waiting(str(answer["waiting"]))
            answer = self._receive(timeout=None)
        self._answer(answer)
        try:
            yield
        finally:
            with contextlib.suppress(UserError):
                self.request({"op": "end"})

    def io(self, ops: list[JSON]) -> list[list[int]]:
        reads = self.request({"op": "io", "ops": ops})["reads"]
        assert isinstance(reads, list)
        return reads

    def action(self, name: str, **args: JSON) -> JSON:
        return self.request({"op": "action", "name": name, "args": args})["result"]

    def close(self) -> None:
        self.sock.close()


class LivePort:
    """``PortIO`` over a ``LiveClient``: writes wait for the next read, which takes them
    along; ``read_data`` reads a run of data bytes in one access."""

    def __init__(self, client: LiveClient) -> None:
        self.client = client
        self._pending: list[JSON] = []

    def write(self, offset: int, value: int) -> None:
        last = self._pending[-1] if self._pending else None
        if last is not None and last[1] == offset and offset == PORT_DATA:
            last[2].append(value & 0xFF)
        else:
            self._pending.append(["w", offset, [value & 0xFF]])

    def _read(self, offset: int, count: int) -> list[int]:
        ops, self._pending = [*self._pending, ["r", offset, count]], []
        return self.client.io(ops)[-1]

    def read(self, offset: int) -> int:
        return self._read(offset, 1)[0]

    def read_data(self, count: int) -> bytes:
        return bytes(self._read(PORT_DATA, count))

    def flush(self) -> None:
        if self._pending:
            ops, self._pending = self._pending, []
            self.client.io(ops)

    def now_ms(self) -> float:
        return time.monotonic() * 1000.0


def open_live(directory: Path, base: int) -> LiveClient | None:
    """The live board at ``base`` if one serves it; a socket left behind by a server that
    died is removed (only when the board's lock is free: a starting server keeps its)."""
    path = socket_path(directory, base)
    if not path.exists():
        return None
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.connect(str(path))
    except (ConnectionRefusedError, FileNotFoundError):
        sock.close()
        if is_free(lock_file(directory, base)):  # so no live board can be serving it
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
        return None
    except PermissionError:
        sock.close()
        raise UserError(
            f"{path}: a live board serves port {port_name(base)} but this user may not "
            "talk to it (the socket belongs to its owner)"
        ) from None
    except OSError as exc:
        sock.close()
        raise UserError(f"{path}: cannot reach the live board: {exc.strerror or exc}") from None
    client = LiveClient(sock, path)
    client.hello()
    return client


def is_served(directory: Path, base: int) -> bool:
    client = open_live(directory, base)
    if client is None:
        return False
    client.close()
    return True


def refuse_if_served(directory: Path, base: int) -> None:
    """A second server for one board would wait on its lock forever: say who serves it."""
    client = open_live(directory, base)
    if client is not None:
        server = client.server
        client.close()
        raise UserError(
            f"board {port_name(base)} is already served live by "
            f"{server.get('command', 'another process')} (pid {server.get('pid', '?')})",
            ExitCode.FAILED,
        )


def served_by(client: LiveClient) -> str:
    server = client.server
    return f"{server.get('command', 'a live board')} (pid {server.get('pid', '?')})"


def live_action(
    client: LiveClient, settle_ms: float
) -> Callable[[str, dict[str, JSON]], JSON]:
    """Actions on a live board; after a change the command waits as long as a board
    loaded from its state file would run on, so its report shows the effect too."""

    def action(name: str, args: dict[str, JSON]) -> JSON:
        result = client.action(name, **args)
        if name not in VIEWS:
            time.sleep(settle_ms / 1000)
        return result

    return action


def local_action(board: Pc2Board, settle_ms: float) -> Callable[[str, dict[str, JSON]], JSON]:
    """Actions on a board loaded from its state file: the board runs on a little after a
    change, as it would meanwhile, so the command's own report shows the effect."""

    def action(name: str, args: dict[str, JSON]) -> JSON:
        result = run_action(board, name, args)
        if name not in VIEWS:
            board.advance(settle_ms)
        return result

    return action
