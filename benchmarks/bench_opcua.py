"""What ``serve --opcua`` costs: the time until it serves, and the live board's CPU time
per second of wall time with and without it.

A board running a program that sets a flag byte every cycle (one slave on the cable) is
served by ``asictl serve`` in a process of its own, alone and with ``--opcua 127.0.0.1:0``
(the default refresh, 0.1 s), alternately; the CPU time is read from /proc over 10 s with
no client connected. In-process, the parts of the start: asyncua's standard address
space (``Server.init``, from the cache after the first start), building the board's
nodes, and one refresh.

With ``--answer N``, only how soon it answers: ``serve --opcua`` started N times, each
until asyncua's client (connecting every 20 ms) has read ``Master.Phase``; the seconds
from the start of the process, and the CPU seconds the server had used by then.

Usage:

    python3 benchmarks/bench_opcua.py [--rounds 2] [--answer N]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_check import cpu_seconds

PROGRAM = "[SETUP]\n1: iiii, 0\n\n[PROGRAM]\n        L   KB 42\n        T   FY 12\n        BE\n"


def served(state: Path, extra: list[str]) -> tuple[float, float]:
    """Seconds until the server said it serves, and its CPU share over 10 s (percent)."""
    started = time.perf_counter()
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", "serve", "--state-dir", str(state), *extra],
        stderr=subprocess.PIPE, text=True,
    )
    assert process.stderr is not None
    wanted = "OPC UA server" if extra else "live at"
    while wanted not in (line := process.stderr.readline()):
        assert line, "the server ended"
    ready = time.perf_counter() - started

    before, wall = cpu_seconds(process.pid), time.perf_counter()
    time.sleep(10)
    share = (cpu_seconds(process.pid) - before) / (time.perf_counter() - wall) * 100
    process.send_signal(signal.SIGINT)
    process.wait(timeout=30)
    return ready, share


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def answered(state: Path) -> tuple[float, float]:
    """Seconds from starting ``serve --opcua`` until a client has read the master's phase,
    and the CPU seconds the server had used by then."""
    from asyncua import Client, ua

    port = free_port()
    started = time.perf_counter()
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", "serve", "--state-dir", str(state),
         "--opcua", f"127.0.0.1:{port}"], stderr=subprocess.DEVNULL,
    )

    async def phase() -> None:
        while True:
            try:
                async with Client(f"opc.tcp://127.0.0.1:{port}/asictl/", timeout=5) as client:
                    ns = await client.get_namespace_index("urn:asictl:board")
                    await client.get_node(ua.NodeId("Master.Phase", ns)).read_value()
                    return
            except (OSError, ua.UaError, TimeoutError):
                await asyncio.sleep(0.02)

    try:
        asyncio.run(phase())
        return time.perf_counter() - started, cpu_seconds(process.pid)
    finally:
        process.send_signal(signal.SIGINT)
        process.wait(timeout=30)


async def parts(state: Path) -> tuple[float, float, int, float]:
    from asyncua.server.server import Server

    from asictl.host.emulated.boards import emulated_board
    from asictl.host.live.board import LiveBoard
    from asictl.opcua.server import BoardSpace, OpcUaOptions, _kept_for_good
    from asictl.opcua.standard_space import CachedStandardSpace

    with emulated_board(0x300, state, save=False) as board:
        async with _kept_for_good():  # as the server builds them
            started = time.perf_counter()
            server = Server(iserver=CachedStandardSpace())
            await server.init()
            initialised = time.perf_counter()
            space = BoardSpace(server, LiveBoard(board), "300h", OpcUaOptions())
            await space.build()
            built = time.perf_counter()
        for _ in range(10):
            await space.refresh()
        refresh = (time.perf_counter() - built) / 10
    return initialised - started, built - initialised, len(space.values), refresh


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--answer", type=int, default=0, metavar="N")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        state = Path(folder)
        (state / "flag.asi").write_text(PROGRAM)
        subprocess.run([sys.executable, "-m", "asictl", "download", str(state / "flag.asi"),
                        "--start", "--state-dir", str(state)], check=True, capture_output=True)
        if args.answer:
            load = os.getloadavg()[0]
            runs = [answered(state) for _ in range(args.answer)]
            seconds = sorted(wall for wall, _ in runs)
            print(f"serve --opcua answered after {seconds[0]:.2f} s at best, "
                  f"{statistics.median(seconds):.2f} s median, {seconds[-1]:.2f} s at worst "
                  f"({args.answer} starts); server CPU by then "
                  f"{statistics.median(cpu for _, cpu in runs):.2f} s median "
                  f"(load average {load:.1f} before, {os.getloadavg()[0]:.1f} after)")
            return
        init, build, nodes, refresh = asyncio.run(parts(state))
        print(f"asyncua Server.init {init:.2f} s; the board's {nodes} variables built in "
              f"{build:.2f} s; one refresh {refresh * 1000:.1f} ms")
        for _ in range(args.rounds):
            for extra in ([], ["--opcua", "127.0.0.1:0"]):
                ready, share = served(state, extra)
                print(f"serve {' '.join(extra) or '(alone)':22} serving after {ready:5.1f} s, "
                      f"CPU {share:4.1f} % (load average {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
