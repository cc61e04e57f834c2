"""Modbus TCP and RTU in front of a ``GatewaySlave``, on one asyncio loop.

One loop owns the board: TCP connections, the serial line and the pacing timer all run on
it, so the master model needs no locks. The framing is ours (MBAP for TCP; for RTU the
3.5-character silence and the CRC-16), because the gateway's diagnostics count exactly
what pymodbus's server framers hide: frames with a bad CRC, frames for other slaves, frames
not answered (slave.py). Master time follows the wall clock: ``PACING_S`` timer plus a
catch-up before every request.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import struct
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from asictl.gateway.slave import GatewaySlave

#: How often master time catches up with the wall clock while nobody asks.
PACING_S = 0.02
#: The RTU end-of-frame silence is never taken shorter than this: ptys and USB adapters
#: deliver bytes in bursts, so 3.5 character times at high baud rates would split frames.
MIN_FRAME_GAP_S = 0.005
_MBAP = struct.Struct(">HHHB")


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

    def __init__(self, slave: GatewaySlave, *, on_tick: Callable[[], None] | None = None):
        self.slave = slave
        #: called from the pacing timer (the CLI saves the board state from here)
        self.on_tick = on_tick
        self.tcp_address: tuple[str, int] | None = None
        self._stop = asyncio.Event()
        self._tasks: set[asyncio.Task[None]] = set()

    # ------------------------------------------------------------------ TCP

    async def _tcp_client(
        self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter
    ) -> None:
        """MBAP: a malformed header ends the connection, as Modbus/TCP asks."""
        task = asyncio.current_task()
        if task is not None:
            self._tasks.add(task)
        try:
            while True:
                header = await reader.readexactly(_MBAP.size)
                tid, protocol, length, unit = _MBAP.unpack(header)
                if not 2 <= length <= 254:
                    break
                pdu = await reader.readexactly(length - 1)
                if protocol != 0:
                    continue
                response = self.slave.frame(unit, pdu)
                if response is not None:
                    writer.write(_MBAP.pack(tid, 0, len(response) + 1, unit) + response)
                    await writer.drain()
        except (asyncio.IncompleteReadError, ConnectionError, asyncio.CancelledError):
            pass
        finally:
            if task is not None:
                self._tasks.discard(task)
            writer.close()

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
        gap = settings.frame_gap_s()
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
            timer.append(loop.call_later(gap, end_of_frame))

        loop.add_reader(fd, readable)
        return line, fd

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
            if server is not None:
                server.close()
                for task in list(self._tasks):
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
) -> Iterator[BackgroundGateway]:
    """Serve ``slave`` from a thread until the block ends (TCP port 0: any free port)."""
    ready = threading.Event()
    errors: list[BaseException] = []
    holder: dict[str, object] = {}

    def main() -> None:
        async def run() -> None:
            server = GatewayServer(slave)
            holder["server"], holder["loop"] = server, asyncio.get_running_loop()
            await server.serve(tcp, rtu, started=ready.set)

        try:
            asyncio.run(run())
        except BaseException as exc:  # reported to the caller's thread
            errors.append(exc)
            ready.set()

    thread = threading.Thread(target=main, name="asictl-gateway", daemon=True)
    thread.start()
    if not ready.wait(timeout) or errors:
        raise RuntimeError(f"the gateway did not start: {errors[0] if errors else 'time-out'}")
    server, loop = holder["server"], holder["loop"]
    assert isinstance(server, GatewayServer) and isinstance(loop, asyncio.AbstractEventLoop)
    try:
        yield BackgroundGateway(server, loop)
    finally:
        loop.call_soon_threadsafe(server.stop)
        thread.join(timeout)
