"""Modbus TCP and RTU in front of a ``GatewaySlave``, on one asyncio loop.

One loop owns the board: TCP connections, the serial line and the pacing timer all run on
it, so the master model needs no locks. The framing is ours (MBAP for TCP; for RTU the
3.5-character silence and the CRC-16), because the gateway's diagnostics count exactly
what pymodbus's server framers hide: frames with a bad CRC, frames for other slaves, frames
not answered (slave.py). Master time follows the wall clock: ``PACING_S`` timer plus a
catch-up before every request.

A gateway must survive its clients. At most ``max_connections`` TCP connections are served
at once. When all are taken, a new one takes the place of the connection least likely to
be a client's: first one that never sent a byte (the oldest), then one silent for
``EVICT_AFTER_S`` since its last request (silent longest), then one stuck inside a frame
(the oldest); when every connection is a client's in use, the new one is closed at once,
so it costs no descriptor. A frame must arrive whole within ``frame_timeout`` of its
first byte (the manual's character time-out, 3.5 character times on the serial line, is
milliseconds; TCP gets half a second), so a header announcing 253 bytes that never come
holds a connection for no longer; a connection silent for ``idle_timeout`` seconds is
closed; and every trouble of that kind (refused connections, idle or stuck ones closed,
the process out of descriptors) is logged as one line when it starts and then at most
once a minute with a count, never once per event.
"""

from __future__ import annotations

import asyncio
import contextlib
import fcntl
import os
import struct
import termios
import time
from collections.abc import Awaitable, Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any, SupportsIndex

from asictl.gateway.addressmap import ExceptionCode
from asictl.gateway.slave import GatewaySlave
from asictl.host.background import NotStarted, in_thread
from asictl.host.condition_log import ConditionLog

#: How often master time catches up with the wall clock while nobody asks.
PACING_S = 0.02
#: The RTU end-of-frame silence is never taken shorter than this: ptys and USB adapters
#: deliver bytes in bursts, so 3.5 character times at high baud rates would split frames.
MIN_FRAME_GAP_S = 0.005
_MBAP = struct.Struct(">HHHB")
#: TCP connections served at once by default (a real gateway takes a handful).
DEFAULT_MAX_CONNECTIONS = 32
#: Seconds a TCP connection may stay silent by default before the gateway closes it.
DEFAULT_IDLE_TIMEOUT_S = 60.0


#: A connection silent this long after a request makes way for a new one when all are
#: taken (one that never sent anything makes way at once).
EVICT_AFTER_S = 1.0
#: Seconds a TCP frame may take from its first byte to its last by default.
DEFAULT_FRAME_TIMEOUT_S = 0.5


class _Reader(asyncio.StreamReader):
    """A stream reader that knows whether any byte came, read or not yet."""

    fed = False

    def feed_data(self, data: Iterable[SupportsIndex]) -> None:
        self.fed = self.fed or bool(data)
        super().feed_data(data)


@dataclass
class _Connection:
    writer: asyncio.StreamWriter
    reader: _Reader
    #: when it last finished a request (or opened)
    since: float = field(default_factory=time.monotonic)
    #: when the frame now arriving began; None between frames
    frame_since: float | None = None

    def spoke(self) -> bool:
        """Whether the client sent anything, even bytes not yet read from the socket."""
        if self.reader.fed:
            return True
        sock = self.writer.get_extra_info("socket")
        if sock is None:
            return False
        pending = bytearray(4)
        try:
            fcntl.ioctl(sock.fileno(), termios.FIONREAD, pending)
        except OSError:
            return False
        return int.from_bytes(pending, "little") > 0


def crc16(data: bytes) -> bytes:
    """Modbus RTU CRC-16 (polynomial A001h reflected, start FFFFh), low byte first."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = crc >> 1 ^ 0xA001 if crc & 1 else crc >> 1
    return crc.to_bytes(2, "little")


@dataclass(frozen=True)
class SerialSettings:
    """An RTU line: the gateway's settings 9600 baud, no parity, 1 stop bit by default."""

    device: str
    baud: int = 9600
    parity: str = "N"
    stopbits: int = 1

    def frame_gap_s(self) -> float:
        """3.5 character times (11 bits each), 1.75 ms above 19200 baud (Modbus spec)."""
        gap = 3.5 * 11 / self.baud if self.baud <= 19200 else 0.00175
        return max(gap, MIN_FRAME_GAP_S)


class GatewayServer:
    """Serves one ``GatewaySlave`` over TCP and/or RTU until ``stop``."""

    def __init__(
        self,
        slave: GatewaySlave,
        *,
        on_tick: Callable[[], None] | None = None,
        max_connections: int = DEFAULT_MAX_CONNECTIONS,
        idle_timeout: float | None = DEFAULT_IDLE_TIMEOUT_S,
        frame_timeout: float = DEFAULT_FRAME_TIMEOUT_S,
        on_request: Callable[[], bool] | None = None,
        log: Callable[[str], None] | None = None,
    ):
        self.slave = slave
        #: called from the pacing timer (the CLI saves the board state from here)
        self.on_tick = on_tick
        self.max_connections = max_connections
        #: seconds; None or 0: connections may stay silent for ever
        self.idle_timeout = idle_timeout or None
        self.frame_timeout = frame_timeout
        #: called after each request, before its answer goes out (the live board saves
        #: a change of its non-volatile state there); False: it could not
        self.on_request = on_request
        self.conditions = ConditionLog(log or (lambda message: None))
        self.tcp_address: tuple[str, int] | None = None
        #: the RTU line while it is open, and its end-of-frame silence
        self._line: Any = None
        self._gap = MIN_FRAME_GAP_S
        self._stop = asyncio.Event()
        self._connections: dict[asyncio.Task[None], _Connection] = {}

    # ------------------------------------------------------------------ TCP

    async def _tcp_client(
        self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter
    ) -> None:
        """MBAP: a malformed header ends the connection, as Modbus/TCP asks."""
        assert isinstance(reader, _Reader)
        if len(self._connections) >= self.max_connections and not self._make_room():
            self.conditions.event(
                "limit", f"gateway: {self.max_connections} connections busy "
                "(--max-connections); refusing further ones",
            )
            writer.close()
            return
        task = asyncio.current_task()
        assert task is not None
        connection = _Connection(writer, reader)
        self._connections[task] = connection
        try:
            while True:
                try:
                    first = await asyncio.wait_for(reader.readexactly(1), self.idle_timeout)
                except TimeoutError:
                    self.conditions.event(
                        "idle", f"gateway: closing connections silent for {self.idle_timeout:g} s"
                        " (--idle-timeout)",
                    )
                    break
                connection.frame_since = time.monotonic()
                try:
                    frame = await asyncio.wait_for(self._frame(reader, first), self.frame_timeout)
                except TimeoutError:
                    self.conditions.event(
                        "frame", "gateway: closing connections that stopped inside a frame "
                        f"for {self.frame_timeout:g} s (--frame-timeout)",
                    )
                    break
                if frame is None:
                    break
                response = self._tcp_request(*frame)
                if response is not None:
                    writer.write(response)
                    await writer.drain()
                connection.frame_since, connection.since = None, time.monotonic()
        except (asyncio.IncompleteReadError, OSError, TimeoutError, asyncio.CancelledError):
            pass
        finally:
            self._connections.pop(task, None)
            writer.close()

    @staticmethod
    async def _frame(
        reader: asyncio.StreamReader, first: bytes
    ) -> tuple[int, int, int, bytes] | None:
        """The rest of an MBAP frame: transaction, protocol, unit and PDU; None if its
        length is not a Modbus frame's."""
        header = first + await reader.readexactly(_MBAP.size - 1)
        tid, protocol, length, unit = _MBAP.unpack(header)
        if not 2 <= length <= 254:
            return None
        return tid, protocol, unit, await reader.readexactly(length - 1)

    def _tcp_request(self, tid: int, protocol: int, unit: int, pdu: bytes) -> bytes | None:
        if protocol != 0:
            return None
        response = self._kept(self.slave.frame(unit, pdu))
        if response is None:
            return None
        return _MBAP.pack(tid, 0, len(response) + 1, unit) + response

    def _kept(self, response: bytes | None) -> bytes | None:
        """``response``, once what the request changed is kept (``on_request``); if it
        cannot be, the answer is exception 04, slave device failure: a write is never
        acknowledged when it is not safe."""
        if self.on_request is None or self.on_request() or not response:
            return response
        return bytes([response[0] | 0x80, ExceptionCode.SLAVE_DEVICE_FAILURE])

    def _make_room(self) -> bool:
        """Close the connection least likely to be a client's, if there is one: one that
        never sent anything, then one silent ``EVICT_AFTER_S`` since its last request,
        then one stuck inside a frame; a client polling keeps its connection."""
        now = time.monotonic()
        mute = [(c.since, task) for task, c in self._connections.items()
                if c.frame_since is None and not c.reader.fed]
        quiet = [(c.since, task) for task, c in self._connections.items()
                 if c.frame_since is None and c.reader.fed and now - c.since >= EVICT_AFTER_S]
        stuck = [(c.frame_since, task) for task, c in self._connections.items()
                 if c.frame_since is not None]
        for candidates in (mute, quiet, stuck):
            for _since, task in sorted(candidates, key=lambda item: item[0]):
                connection = self._connections[task]
                if candidates is mute and connection.spoke():
                    continue  # its first bytes are on their way in
                self.conditions.event(
                    "evict", f"gateway: {self.max_connections} connections open "
                    "(--max-connections); closing the one silent longest for each new one",
                )
                del self._connections[task]
                connection.writer.close()
                task.cancel()
                return True
        return False

    async def _serve_tcp(self, host: str, port: int) -> asyncio.Server:
        loop = asyncio.get_running_loop()

        def protocol() -> asyncio.StreamReaderProtocol:
            return asyncio.StreamReaderProtocol(_Reader(), self._tcp_client)

        server = await loop.create_server(protocol, host, port)
        self.tcp_address = server.sockets[0].getsockname()[:2]
        return server

    # ------------------------------------------------------------------ RTU

    def _open_serial(self, settings: SerialSettings) -> tuple[Any, int]:
        """The open line (a ``serial.Serial``: pyserial has no type information) and its fd."""
        import serial  # pyserial: the optional 'modbus' extra

        line = serial.Serial(
            settings.device, baudrate=settings.baud, parity=settings.parity,
            stopbits=settings.stopbits, bytesize=8, timeout=0,
        )
        loop = asyncio.get_running_loop()
        buffer = bytearray()
        timer: list[asyncio.TimerHandle] = []
        self._line, self._gap = line, settings.frame_gap_s()
        fd = line.fileno()

        def end_of_frame() -> None:
            frame = bytes(buffer)
            buffer.clear()
            timer.clear()
            response = self._rtu_frame(frame)
            if response is not None:
                line.write(response)

        def readable() -> None:
            try:
                chunk = os.read(fd, 512)
            except BlockingIOError:
                return
            except OSError:  # the other end of a pty closed: wait for it to return
                chunk = b""
            if not chunk:
                return
            buffer.extend(chunk)
            if timer:
                timer.pop().cancel()
            timer.append(loop.call_later(self._gap, end_of_frame))

        loop.add_reader(fd, readable)
        return line, fd

    def set_serial(self, baud: int, parity: str, stopbits: int) -> None:
        """The gateway's keys stored another serial setting (manual 5.6): the line takes it
        at once."""
        line = self._line
        if line is None:
            return
        line.baudrate, line.parity, line.stopbits = baud, parity, stopbits
        self._gap = SerialSettings(line.port, baud, parity, stopbits).frame_gap_s()

    def _rtu_frame(self, frame: bytes) -> bytes | None:
        """One frame between silences; short or corrupt frames count as CRC errors."""
        if not frame:
            return None
        unit = frame[0]
        crc_ok = len(frame) >= 4 and crc16(frame[:-2]) == frame[-2:]
        response = self._kept(self.slave.frame(unit, frame[1:-2], crc_ok=crc_ok))
        if response is None:
            return None
        answer = bytes([unit]) + response
        return answer + crc16(answer)

    # ------------------------------------------------------------------ running

    async def _pace(self) -> None:
        while not self._stop.is_set():
            self.slave.sync()
            if self.on_tick is not None:
                self.on_tick()
            with contextlib.suppress(asyncio.TimeoutError):
                await asyncio.wait_for(self._stop.wait(), PACING_S)

    async def serve(
        self,
        tcp: tuple[str, int] | None = None,
        rtu: SerialSettings | None = None,
        started: Callable[[], None] | None = None,
    ) -> None:
        """Serve until ``stop()``; ``started`` is called once the endpoints are open."""
        if tcp is None and rtu is None:
            raise ValueError("nothing to serve: give a TCP address or a serial line")
        loop = asyncio.get_running_loop()
        loop.set_exception_handler(self.conditions.loop_handler("gateway"))
        server = await self._serve_tcp(*tcp) if tcp else None
        line: Any = None
        fd = -1
        if rtu is not None:
            line, fd = self._open_serial(rtu)
        try:
            if started is not None:
                started()
            await self._pace()
        finally:
            if line is not None:
                asyncio.get_running_loop().remove_reader(fd)
                line.close()
                self._line = None
            if server is not None:
                server.close()
                for task in list(self._connections):
                    task.cancel()
                await server.wait_closed()

    def stop(self) -> None:
        self._stop.set()


class BackgroundGateway:
    """A ``GatewayServer`` on a thread of its own, for tests and embedding."""

    def __init__(self, server: GatewayServer, loop: asyncio.AbstractEventLoop) -> None:
        self.server = server
        self.loop = loop

    def call(self, function: Callable[[], object], timeout: float = 5.0) -> object:
        """Run ``function`` on the server's loop (the board belongs to that thread)."""

        async def run() -> object:
            return function()

        return asyncio.run_coroutine_threadsafe(run(), self.loop).result(timeout)


@contextlib.contextmanager
def background_gateway(
    slave: GatewaySlave,
    tcp: tuple[str, int] | None = ("127.0.0.1", 0),
    rtu: SerialSettings | None = None,
    timeout: float = 5.0,
    **options: Any,
) -> Iterator[BackgroundGateway]:
    """Serve ``slave`` from a thread until the block ends (TCP port 0: any free port);
    ``options`` go to ``GatewayServer``."""
    def serve(server: GatewayServer, ready: Callable[[], None]) -> Awaitable[None]:
        return server.serve(tcp, rtu, started=ready)

    try:
        with in_thread("asictl-gateway", lambda: contextlib.nullcontext(
            GatewayServer(slave, **options)
        ), serve, timeout) as (server, loop):
            yield BackgroundGateway(server, loop)
    except NotStarted as exc:
        raise RuntimeError(f"the gateway did not start: {exc}") from None
