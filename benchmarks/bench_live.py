"""Time the live board: a 16 KB download to a served board, the monitor's refresh rate,
and how soon an input set with ``asictl bus inputs`` shows in a program's output.

``asictl serve`` runs as its own process with a temporary state directory (as a user runs
it); the client side runs here, as the commands do:

- download: the download procedure over the socket (configuration, 70 blocks through the
  program buffer, the read-back, the reset), median of several runs;
- refresh: ``MonitorSource.snapshot`` (what one monitor refresh reads) per second;
- input to output: setting an input of the board's cable, then polling ``status`` until
  the program's output follows (the program ``Q 17.3 = I 4.0``), median;
- one-shot commands: ``status``, ``bus inputs``, ``force`` and ``write`` each as a whole
  process (the installed ``asictl`` script, start-up included), wall and CPU time
  (user + system), medians of ``--runs``; first alone, then while a monitor (a process
  reading ``MonitorSource.snapshot`` 4 times a second, as the monitor refreshes) and a
  recorder (``asictl record``, which reads the board as often as it answers) are attached;
- the program view: the server process's CPU time per second of wall time with no
  monitor, with a monitor refreshing its slave view 4 times a second, with its program
  view open (each refresh also asks for the latest cycle's lines, for which the board
  runs one cycle under line hooks), and with no monitor again (the hooks are gone: the
  figure must be the first one's); and how long one ``lines`` request takes. The program
  toggles a flag every cycle, so the board runs every program cycle throughout;
- a mixed load (live_load.py) on ``gateway serve`` with Modbus and OPC UA: ``--clients``
  at once for ``--load-seconds``, 140 of 200 running live commands (more than the live
  socket's 32 slots: the rest wait their turn), 30 polling Modbus and 30 reading OPC UA
  (each within its server's 32 connections): answers, errors (the target is none),
  p50/p99 per kind, and how much the server's memory grew.

Usage:

    python3 benchmarks/bench_live.py [--runs 5] [--seconds 10] [--clients 200]
        [--load-seconds 60] [--load-only | --one-shot-only]
"""

from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from bench_check import console_script, cpu_seconds, timed_with_cpu
from bench_compile import largest_fitting
from live_load import mixed_load, report
from live_load import serve as serve_gateway

from asictl.build import build
from asictl.host.connection import MasterAddress, open_board
from asictl.host.transfer import StartMode, download
from asictl.monitor.source import MonitorSource
from asictl.source import from_string

PROGRAM = """[SETUP]
4: iiii, 0
17: oooo, 0
[PROGRAM]
        A   I 4.0
        =   Q 17.3
        BE
[END]
"""


def serve(state: Path) -> subprocess.Popen[str]:
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", "serve", "--state-dir", str(state)],
        stderr=subprocess.PIPE, text=True, env=os.environ.copy(),
    )
    assert process.stderr is not None and "live at" in process.stderr.readline()
    return process


def time_download(address: MasterAddress, runs: int) -> tuple[float, int]:
    _, image = largest_fitting()
    times = []
    for _ in range(runs):
        with open_board(address) as master:
            started = time.perf_counter()
            download(master.transport, image, start=StartMode.STOP)
            times.append(time.perf_counter() - started)
    return statistics.median(times), len(image.to_bytes())


def refresh_rate(address: MasterAddress, seconds: float) -> float:
    source = MonitorSource(address)
    source.snapshot()
    count, started = 0, time.perf_counter()
    while time.perf_counter() - started < seconds:
        assert source.snapshot().status is not None
        count += 1
    return count / (time.perf_counter() - started)


def input_to_output(address: MasterAddress, runs: int) -> float:
    built = build(from_string("p.asi", PROGRAM))
    assert built.image is not None
    with open_board(address) as master:
        download(master.transport, built.image, start=StartMode.START)
        master.emulated("match")
    times = []
    for n in range(2 * runs):
        value = (n + 1) % 2
        with open_board(address) as master:
            started = time.perf_counter()
            master.emulated("inputs", changes=[[4, 1, value]])
        while True:
            with open_board(address) as master:
                status = master.status()
            if status.slaves["17"].outputs == value << 3:
                break
        times.append(time.perf_counter() - started)
    return statistics.median(times)


#: The one-shot commands timed as whole processes, against the served board running
#: ``PROGRAM`` (slaves 4 and 17 on its cable).
ONE_SHOT = (
    ("status",),
    ("bus", "inputs", "I 4.0=1"),
    ("force", "F 10.0=1"),
    ("write", "F 11.0=1"),
)
#: A monitor's reads: the status 4 times a second, each in a session of its own.
MONITOR = """
import sys, time
from asictl.host.connection import MasterAddress
from asictl.monitor.source import MonitorSource
source = MonitorSource(MasterAddress(state_dir=sys.argv[1]))
while True:
    started = time.monotonic()
    source.snapshot()
    time.sleep(max(0.0, 0.25 - (time.monotonic() - started)))
"""


def one_shot(state: Path, runs: int) -> dict[str, tuple[float, float]]:
    """Each of ``ONE_SHOT`` as a whole process: median wall and CPU seconds."""
    asictl = console_script() or sys.exit("asictl is not installed (pip install -e .)")
    return {
        " ".join(command): timed_with_cpu([asictl, *command, "--state-dir", str(state)], runs)
        for command in ONE_SHOT
    }


def attached(state: Path, tmp: Path) -> list[subprocess.Popen[bytes]]:
    """A monitor and a recorder reading the served board, each a process of its own."""
    monitor = subprocess.Popen([sys.executable, "-c", MONITOR, str(state)])
    recorder = subprocess.Popen(
        [sys.executable, "-m", "asictl", "record", "--duration", "1h", "--force",
         "-o", str(tmp / "bench.scenario.toml"), "--state-dir", str(state)],
        stderr=subprocess.DEVNULL,
    )
    time.sleep(2.0)  # both started and reading
    for process in (monitor, recorder):
        if process.poll() is not None:
            sys.exit(f"{process.args!r} ended ({process.returncode})")
    return [monitor, recorder]


def one_shots(state: Path, tmp: Path, runs: int) -> None:
    alone = one_shot(state, runs)
    processes = attached(state, tmp)
    try:
        busy = one_shot(state, runs)
    finally:
        for process in processes:
            process.send_signal(signal.SIGTERM)
            process.wait(timeout=20)
    print(f"one-shot commands, whole process (medians of {runs}; wall / CPU, alone and "
          "with a monitor and a recorder attached):")
    for name, (wall, cpu) in alone.items():
        busy_wall, busy_cpu = busy[name]
        print(f"  asictl {name:<22} {wall:.3f} s / {cpu:.3f} s   "
              f"attached {busy_wall:.3f} s / {busy_cpu:.3f} s")


BUSY = """[SETUP]
4: iiii, 0
17: oooo, 0
[PROGRAM]
        AN  F 0.0
        =   F 0.0
***
        A   I 4.0
        A   F 0.0
        =   Q 17.3
        BE
[END]
"""


def server_share(pid: int, seconds: float, work: Callable[[], None] | None) -> float:
    """The server's CPU seconds per wall second while ``work`` runs 4 times a second."""
    cpu, started = cpu_seconds(pid), time.perf_counter()
    while (now := time.perf_counter()) - started < seconds:
        if work is not None:
            work()
        time.sleep(max(0.0, 0.25 - (time.perf_counter() - now)))
    return (cpu_seconds(pid) - cpu) / (time.perf_counter() - started)


def program_view(address: MasterAddress, pid: int, seconds: float) -> None:
    built = build(from_string("busy.asi", BUSY))
    assert built.image is not None
    with open_board(address) as master:
        download(master.transport, built.image, start=StartMode.START)
        master.emulated("match")
    monitor = MonitorSource(address)
    shares = {"no monitor": server_share(pid, seconds, None)}
    shares["monitor, slave view"] = server_share(pid, seconds, monitor.snapshot)
    monitor.watch_lines = True
    times: list[float] = []

    def refresh() -> None:
        started = time.perf_counter()
        assert monitor.snapshot().lines is not None
        times.append(time.perf_counter() - started)

    shares["monitor, program view"] = server_share(pid, seconds, refresh)
    shares["no monitor again"] = server_share(pid, seconds, None)
    for name, share in shares.items():
        print(f"server CPU, {name}: {share * 100:.1f} %")
    with open_board(address) as master:
        started = time.perf_counter()
        for _ in range(20):
            master.emulated("lines")
        each = (time.perf_counter() - started) / 20
    print(f"one 'lines' request: {each * 1000:.1f} ms; a program-view refresh "
          f"{statistics.median(times) * 1000:.1f} ms (median)")


def load(clients: int, seconds: float) -> None:
    """The mixed load: 70 % live commands, 15 % Modbus, 15 % OPC UA."""
    modbus = opcua = min(30, clients * 15 // 100)
    live = clients - modbus - opcua
    with tempfile.TemporaryDirectory() as tmp:
        served = serve_gateway(Path(tmp) / "state")
        try:
            before = served.rss_kb()
            tallies = mixed_load(served, live=live, modbus=modbus, opcua=opcua,
                                 seconds=seconds)
            after = served.rss_kb()
        finally:
            served.stop()
    errors = sum(sum(tally.errors.values()) for tally in tallies.values())
    print(f"mixed load, {clients} clients ({live} live, {modbus} Modbus, {opcua} OPC UA) "
          f"for {seconds:g} s: {errors} errors; server memory {before / 1024:.0f} MB -> "
          f"{after / 1024:.0f} MB")
    print(report(tallies))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=10.0,
                        help="how long each CPU share is measured")
    parser.add_argument("--clients", type=int, default=200, help="clients of the mixed load")
    parser.add_argument("--load-seconds", type=float, default=60.0)
    parser.add_argument("--load-only", action="store_true", help="only the mixed load")
    parser.add_argument("--one-shot-only", action="store_true",
                        help="only the one-shot commands")
    args = parser.parse_args()
    if args.load_only:
        load(args.clients, args.load_seconds)
        return
    with tempfile.TemporaryDirectory() as tmp:
        state = Path(tmp) / "state"
        process = serve(state)
        try:
            address = MasterAddress(state_dir=state)
            if args.one_shot_only:
                input_to_output(address, 1)  # the program, and its slaves on the cable
                one_shots(state, Path(tmp), args.runs)
                return
            seconds, size = time_download(address, args.runs)
            print(f"download of {size} bytes to a served board: {seconds:.2f} s (median)")
            rate = refresh_rate(address, 3.0)
            print(f"monitor refresh (status without the image): {rate:.0f} per second")
            latency = input_to_output(address, args.runs)
            print(f"input set -> output seen in status: {latency * 1000:.0f} ms (median)")
            one_shots(state, Path(tmp), args.runs)
            program_view(address, process.pid, args.seconds)
        finally:
            process.send_signal(signal.SIGTERM)
            process.wait(timeout=20)
    load(args.clients, args.load_seconds)


if __name__ == "__main__":
    main()
