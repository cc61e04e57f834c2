"""Time ``asictl fleet backup`` of twelve emulated gateways into a new archive (target:
< 60 s), and again when nothing changed.

Each gateway is ``asictl gateway serve`` in a process of its own on a loopback port, in
front of its own live board running demos/blink.asi (as a plant's masters run their
programs meanwhile). The whole command is timed as a user runs it (a new process: start-up,
reading the inventory, twelve uploads and status reads, writing the folders, one git
commit), and the second run, which finds nothing changed and commits nothing. The
command's own CPU time (and git's) is given beside the wall time: the rest is the
gateways' answering, on a machine they share with the twelve boards they run.

Usage:

    python3 benchmarks/bench_fleet.py [--runs 3] [--gateways 12] [--jobs 8]
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def asictl(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "asictl", *args], capture_output=True,
                          text=True, env=env, check=False)


def start_gateways(root: Path, count: int) -> tuple[list[subprocess.Popen[str]], list[int]]:
    first = root / "board-00"
    first.mkdir(mode=0o700)
    done = asictl("download", str(ROOT / "demos" / "blink.asi"), "--start", "--state-dir",
                  str(first))
    assert done.returncode == 0, done.stderr
    processes, ports = [], []
    for n in range(count):
        state = root / f"board-{n:02}"
        if n:
            state.mkdir(mode=0o700)
            shutil.copy(first / "pc2-300h.json", state)
        processes.append(subprocess.Popen(
            [sys.executable, "-m", "asictl", "gateway", "serve", "--tcp", "127.0.0.1:0"],
            stderr=subprocess.PIPE, text=True, env={**os.environ, "ASICTL_STATE_DIR": str(state)},
        ))
    for process in processes:
        assert process.stderr is not None
        line = ""
        while "serving" not in line:
            line = process.stderr.readline()
            assert line, "a gateway ended"
        match = re.search(r"tcp 127\.0\.0\.1:(\d+)", line)
        assert match, line
        ports.append(int(match.group(1)))
    return processes, ports


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--gateways", type=int, default=12)
    parser.add_argument("--jobs", type=int, default=8)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        processes, ports = start_gateways(root, args.gateways)
        try:
            plant = root / "plant.toml"
            plant.write_text("".join(
                f'[masters.gw-{n:02}]\nmodbus = "tcp://127.0.0.1:{port}"\n\n'
                for n, port in enumerate(ports)
            ))
            first: list[float] = []
            again: list[float] = []
            cpu: list[float] = []
            for run in range(args.runs):
                archive = root / f"archive-{run}"
                for times in (first, again):
                    used = resource.getrusage(resource.RUSAGE_CHILDREN)
                    started = time.perf_counter()
                    result = asictl("fleet", "backup", str(plant), "--into", str(archive),
                                    "--jobs", str(args.jobs))
                    times.append(time.perf_counter() - started)
                    now = resource.getrusage(resource.RUSAGE_CHILDREN)
                    if times is first:
                        cpu.append(now.ru_utime + now.ru_stime - used.ru_utime - used.ru_stime)
                    assert result.returncode == 0, result.stdout + result.stderr
                commits = subprocess.run(["git", "-C", str(archive), "rev-list", "--count",
                                          "HEAD"], capture_output=True, text=True, check=True)
                assert commits.stdout.strip() == "1", "two runs, one commit"
        finally:
            for process in processes:
                process.send_signal(signal.SIGINT)
            for process in processes:
                process.wait(timeout=30)
    print(f"fleet backup of {args.gateways} gateways, --jobs {args.jobs}, new archive "
          f"(median of {args.runs}): {statistics.median(first):.2f} s "
          f"(max {max(first):.2f} s); the command's own CPU time (with git): "
          f"{statistics.median(cpu):.2f} s; load average {os.getloadavg()[0]:.1f}")
    print(f"the same again, nothing changed, no commit: {statistics.median(again):.2f} s")


if __name__ == "__main__":
    main()
