"""A mixed load on one live board: clients running live commands (``asictl status``
through the board's socket, a connection per command as a user's commands make), Modbus
polls (each client its own TCP connection to ``gateway serve``) and OPC UA reads (each
client its own session), each of those every ``POLL_S`` as an HMI or SCADA polls, all at
once for a while; every failure counted with its text.

Used by bench_live.py (200 clients) and, sized for CI, by tests/host/test_live_load.py.
"""

from __future__ import annotations

import asyncio
import os
import re
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from asictl.host.connection import MasterAddress, open_board

#: How often a Modbus or OPC UA client asks (an HMI's refresh).
POLL_S = 0.1


@dataclass
class Tally:
    """Latencies and failures of one kind of client, filled from many threads."""

    times: list[float] = field(default_factory=list)
    errors: Counter[str] = field(default_factory=Counter)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def timed(self, work: Callable[[], object]) -> None:
        started = time.perf_counter()
        try:
            work()
        except Exception as exc:
            with self.lock:
                self.errors[re.sub(r"\d+", "N", f"{type(exc).__name__}: {exc}")[:160]] += 1
            return
        with self.lock:
            self.times.append(time.perf_counter() - started)

    def percentile(self, share: float) -> float:
        ordered = sorted(self.times)
        return ordered[min(len(ordered) - 1, int(share * len(ordered)))] if ordered else 0.0


@dataclass
class Served:
    process: subprocess.Popen[str]
    state: Path
    modbus: tuple[str, int]
    opcua: str

    def rss_kb(self) -> int:
        text = Path(f"/proc/{self.process.pid}/status").read_text()
        return int(re.search(r"VmRSS:\s+(\d+)", text).group(1))  # type: ignore[union-attr]

    def stop(self) -> None:
        self.process.send_signal(signal.SIGTERM)
        self.process.wait(timeout=30)


def serve(state: Path) -> Served:
    """``gateway serve`` with Modbus TCP and OPC UA on free loopback ports."""
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", "gateway", "serve", "--state-dir", str(state),
         "--tcp", "127.0.0.1:0", "--opcua", "127.0.0.1:0"],
        stderr=subprocess.PIPE, text=True, env=os.environ.copy(),
    )
    assert process.stderr is not None
    modbus = opcua = None
    while modbus is None or opcua is None:
        line = process.stderr.readline()
        assert line, "the server ended"
        if found := re.search(r"serving tcp ([\d.]+):(\d+)", line):
            modbus = (found.group(1), int(found.group(2)))
        if found := re.search(r"OPC UA server for board \S+ at (opc\.tcp://\S+)", line):
            opcua = found.group(1)
    threading.Thread(target=process.stderr.read, daemon=True).start()  # never blocks it
    return Served(process, state, modbus, opcua)


def _live_client(state: Path, until: float, tally: Tally) -> None:
    address = MasterAddress(state_dir=state)

    def status() -> None:
        with open_board(address) as master:
            master.status()

    while time.monotonic() < until:
        tally.timed(status)


def _modbus_client(where: tuple[str, int], until: float, tally: Tally) -> None:
    """Reads of 8 holding registers, transaction by transaction on one connection."""
    with socket.create_connection(where, timeout=30) as sock:
        tid = 0

        def poll() -> None:
            nonlocal tid
            tid = (tid + 1) & 0xFFFF
            sock.sendall(struct.pack(">HHHBBHH", tid, 0, 6, 1, 3, 0, 8))
            header = _exactly(sock, 7)
            length = struct.unpack(">HHHB", header)[2]
            pdu = _exactly(sock, length - 1)
            if struct.unpack(">H", header[:2])[0] != tid or pdu[0] != 3:
                raise RuntimeError(f"Modbus answer {pdu.hex()}")

        while (now := time.monotonic()) < until:
            tally.timed(poll)
            time.sleep(max(0.0, POLL_S - (time.monotonic() - now)))


def _exactly(sock: socket.socket, size: int) -> bytes:
    data = b""
    while len(data) < size:
        chunk = sock.recv(size - len(data))
        if not chunk:
            raise ConnectionError("the gateway closed the connection")
        data += chunk
    return data


def _opcua_clients(url: str, count: int, until: float, tally: Tally) -> None:
    from asyncua import Client

    async def one() -> None:
        client = Client(url, timeout=30)
        try:
            await client.connect()
        except Exception as exc:
            tally.errors[f"connect: {type(exc).__name__}: {exc}"] += 1
            return
        try:
            while time.monotonic() < until:
                started = time.perf_counter()
                try:
                    await client.nodes.server_state.read_value()
                except Exception as exc:
                    tally.errors[f"{type(exc).__name__}: {exc}"[:160]] += 1
                else:
                    tally.times.append(time.perf_counter() - started)
                await asyncio.sleep(max(0.0, POLL_S - (time.perf_counter() - started)))
        finally:
            await client.disconnect()

    async def all_of_them() -> None:
        await asyncio.gather(*(one() for _ in range(count)))

    asyncio.run(all_of_them())


def mixed_load(
    served: Served, *, live: int, modbus: int, opcua: int, seconds: float
) -> dict[str, Tally]:
    """``live`` + ``modbus`` + ``opcua`` clients at once for ``seconds``."""
    tallies = {"live": Tally(), "modbus": Tally(), "opcua": Tally()}
    until = time.monotonic() + seconds
    threads = [threading.Thread(target=_live_client, args=(served.state, until, tallies["live"]))
               for _ in range(live)]
    threads += [threading.Thread(target=_modbus_client,
                                 args=(served.modbus, until, tallies["modbus"]))
                for _ in range(modbus)]
    if opcua:
        threads.append(threading.Thread(target=_opcua_clients,
                                        args=(served.opcua, opcua, until, tallies["opcua"])))
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(seconds + 120)
    return tallies


def report(tallies: dict[str, Tally]) -> str:
    lines = []
    for kind, tally in tallies.items():
        lines.append(f"{kind}: {len(tally.times)} answers, {sum(tally.errors.values())} errors, "
                     f"p50 {tally.percentile(0.5) * 1000:.0f} ms, "
                     f"p99 {tally.percentile(0.99) * 1000:.0f} ms")
        lines += [f"  {count} x {text}" for text, count in tally.errors.most_common(5)]
    return "\n".join(lines)
