"""Modbus TCP and RTU in front of a ``GatewaySlave``, on one asyncio loop.

One loop owns the board: TCP connections, the serial line and the pacing timer all run on
it, so the master model needs no locks. The framing is ours (MBAP for TCP; for RTU the
3.5-character silence and the CRC-16), because the gateway's diagnostics count exactly
what pymodbus's server framers hide: frames with a bad CRC, frames for other slaves, frames
not answered (slave.py). Master time follows the wall clock: ``PACING_S`` timer plus a
catch-up before every request.

A gateway must survive its clients. At most ``max_connections`` TCP connections are served
at once: a new one beyond takes the place of the connection silent longest (if one has
been silent ``EVICT_AFTER_S``), else it is closed at once, so it costs no descriptor; a
connection silent for ``idle_timeout`` seconds is closed; and every trouble of that kind (refused
connections, idle ones closed, the process out of descriptors) is logged as one line when
it starts and then at most once a minute with a count, never once per event.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import struct
import time
from collections.abc import Awaitable, Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

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


#: A connection silent this long makes way for a new one when all are taken.
EVICT_AFTER_S = 1.0


@dataclass
class _Connection:
    writer: asyncio.StreamWriter
    #: when it last finished a request (or opened)
    since: float = field(default_factory=time.monotonic)
    #: inside a request: never closed to make room
    busy: bool = False


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
        log: Callable[[str], None] | None = None,
    ):
        self.slave = slave
        #: called from the pacing timer (the CLI saves the board state from here)
        self.on_tick = on_tick
        self.max_connections = max_connections
        #: seconds; None or 0: connections may stay silent for ever
        self.idle_timeout = idle_timeout or None
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
        if len(self._connections) >= self.max_connections and not self._make_room():
            self.conditions.event(
                "limit", f"gateway: {self.max_connections} connections busy "
                "(--max-connections); refusing further ones",
            )
            writer.close()
            return
        task = asyncio.current_task()
        assert task is not None
        connection = _Connection(writer)
        self._connections[task] = connection
        try:
            while True:
                try:
                    header = await asyncio.wait_for(
                        reader.readexactly(_MBAP.size), self.idle_timeout
                    )
                except TimeoutError:
                    self.conditions.event(
                        "idle", f"gateway: closing connections silent for {self.idle_timeout:g} s"
                        " (--idle-timeout)",
                    )
                    break
                connection.busy = True
                tid, protocol, length, unit = _MBAP.unpack(header)
                if not 2 <= length <= 254:
                    break
                pdu = await asyncio.wait_for(reader.readexactly(length - 1), self.idle_timeout)
                if protocol != 0:
                    continue
                response = self.slave.frame(unit, pdu)
                if response is not None:
                    writer.write(_MBAP.pack(tid, 0, len(response) + 1, unit) + response)
                    await writer.drain()
                connection.busy, connection.since = False, time.monotonic()
        except (asyncio.IncompleteReadError, OSError, TimeoutError, asyncio.CancelledError):
            pass
        finally:
            self._connections.pop(task, None)
            writer.close()

    def _make_room(self) -> bool:
        """Close the connection silent longest, if one has been silent ``EVICT_AFTER_S``:
        a client that polls keeps its connection, one that only holds it makes way."""
        now = time.monotonic()
        quiet = [(c.since, task) for task, c in self._connections.items() if not c.busy]
        if not quiet:
            return False
        since, task = min(quiet, key=lambda item: item[0])
        if now - since < EVICT_AFTER_S:
            return False
        self.conditions.event(
            "evict", f"gateway: {self.max_connections} connections open (--max-connections); "
            "closing the one silent longest for each new one",
        )
        connection = self._connections.pop(task)
        connection.writer.close()
        task.cancel()
        return True

    def _loop_trouble(self, loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
        """asyncio's own troubles (above all accept() failing when the process is out of
        descriptors, which asyncio retries every second) as one line per condition."""
        message = str(context.get("message", "event loop error"))
        exception = context.get("exception")
        detail = f": {exception}" if exception is not None else ""
        self.conditions.event(message, f"gateway: {message}{detail}")

    async def _serve_tcp(self, host: str, port: int) -> asyncio.Server:
        server = await asyncio.start_server(self._tcp_client, host, port)
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
        response = self.slave.frame(unit, frame[1:-2], crc_ok=crc_ok)
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
        loop.set_exception_handler(self._loop_trouble)
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
