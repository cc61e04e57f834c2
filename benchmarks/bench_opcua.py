"""What ``serve --opcua`` costs: the time until it serves, and the live board's CPU time
per second of wall time with and without it.

A board running a program that sets a flag byte every cycle (one slave on the cable) is
served by ``asictl serve`` in a process of its own, alone and with ``--opcua 127.0.0.1:0``
(the default refresh, 0.1 s), alternately; the CPU time is read from /proc over 10 s with
no client connected. In-process, the parts of the start: asyncua's standard address
space (``Server.init``), building the board's nodes, and one refresh.

Usage:

    python3 benchmarks/bench_opcua.py [--rounds 2]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import signal
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


async def parts(state: Path) -> tuple[float, float, int, float]:
    from asyncua.server.server import Server

    from asictl.host.emulated.boards import emulated_board
    from asictl.host.live.board import LiveBoard
    from asictl.opcua.server import BoardSpace, OpcUaOptions

    with emulated_board(0x300, state, save=False) as board:
        started = time.perf_counter()
        server = Server()
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
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        state = Path(folder)
        (state / "flag.asi").write_text(PROGRAM)
        subprocess.run([sys.executable, "-m", "asictl", "download", str(state / "flag.asi"),
                        "--start", "--state-dir", str(state)], check=True, capture_output=True)
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
