"""What ``serve --http`` costs beside an idle board: the live board's CPU time per second
of wall time alone, with the web server and no client, and with 10 pages listening to the
event stream.

A board running a program that writes a flag byte every cycle (one slave on the cable) is
served by ``asictl serve`` in a process of its own; the CPU time is read from /proc over
10 s. The 10 clients are threads of this process, each reading ``/api/events`` with a
watch list of two operands, as the page does (the board's status is read every 0.05 s
while anyone listens, and sent only when it changed).

Usage:

    python3 benchmarks/bench_web.py [--rounds 2] [--clients 10]
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx
from bench_check import cpu_seconds

PROGRAM = "[SETUP]\n1: iiii, 0\n\n[PROGRAM]\n        L   KB 42\n        T   FY 12\n        BE\n"


def listen(url: str, stop: threading.Event, heard: list[int]) -> None:
    with contextlib.suppress(httpx.HTTPError), httpx.Client(base_url=url, timeout=30) as client, \
            client.stream("GET", "/api/events", params={"watch": ["FY 12", "I 1.0"]}) as events:
        for line in events.iter_lines():
            if line.startswith("data: "):
                heard.append(1)
            if stop.is_set():
                return


def served(state: Path, http: bool, clients: int) -> tuple[float, int]:
    """The server's CPU share over 10 s (percent), and the messages the clients heard."""
    extra = ["--http", "127.0.0.1:0"] if http else []
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", "serve", "--state-dir", str(state), *extra],
        stderr=subprocess.PIPE, text=True,
    )
    assert process.stderr is not None
    url = None
    while url is None:
        line = process.stderr.readline()
        assert line, "the server ended"
        found = re.search(r"at (http://\S+)" if http else r"live at (\S+)", line)
        url = found.group(1) if found else None
    stop, heard = threading.Event(), []
    threads = [threading.Thread(target=listen, args=(url, stop, heard), daemon=True)
               for _ in range(clients)]
    for thread in threads:
        thread.start()
    time.sleep(2)  # connected, first messages sent
    before, wall = cpu_seconds(process.pid), time.perf_counter()
    time.sleep(10)
    share = (cpu_seconds(process.pid) - before) / (time.perf_counter() - wall) * 100
    stop.set()
    process.send_signal(signal.SIGINT)
    process.wait(timeout=30)
    return share, len(heard)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--clients", type=int, default=10)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        state = Path(folder)
        state.chmod(0o700)
        (state / "flag.asi").write_text(PROGRAM)
        subprocess.run([sys.executable, "-m", "asictl", "download", str(state / "flag.asi"),
                        "--start", "--state-dir", str(state)], check=True, capture_output=True)
        for _ in range(args.rounds):
            for name, http, clients in (("alone", False, 0), ("--http, no client", True, 0),
                                        (f"--http, {args.clients} clients", True,
                                         args.clients)):
                share, heard = served(state, http, clients)
                print(f"serve {name:22} CPU {share:4.1f} % of a core, {heard} messages "
                      f"(load average {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
