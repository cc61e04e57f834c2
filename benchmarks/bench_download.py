"""Time a download of a full 16 KB image to the emulated PC2 board (target: < 2 s).

The image is bench_compile's: the longest generated program (bit logic, byte arithmetic,
timers, counters, jumps) whose image still fits the EEPROM. It times

- the download procedure in process: configuration, 70 blocks through the program
  buffer, the read-back of every block, the reset: median of several runs, each on a
  new board;
- ``asictl download FILE.hex`` as a whole process (Python start-up, loading and saving
  the board's state included), median of several runs.

Usage:

    python3 benchmarks/bench_download.py [--runs 5]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_compile import largest_fitting

from asictl.board.board import Pc2Board
from asictl.host.transfer import Pc2Transport, StartMode, download
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.image.eeprom import ProgramImage
from asictl.platform.master import EEPROM_SIZE


def time_in_process(image: ProgramImage, runs: int) -> float:
    times = []
    for _ in range(runs):
        board = Pc2Board()
        transport = Pc2Transport(Pc2Driver(EmulatedPort(board)))
        started = time.perf_counter()
        download(transport, image, start=StartMode.START)
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def time_whole_process(image: ProgramImage, runs: int) -> float:
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        hex_file = Path(tmp) / "big.hex"
        hex_file.write_text(image.to_hex())
        command = [sys.executable, "-m", "asictl", "download", str(hex_file), "--start",
                   "--state-dir", str(Path(tmp) / "state")]
        subprocess.run(command, check=True, capture_output=True)  # warm-up
        for _ in range(runs):
            started = time.perf_counter()
            subprocess.run(command, check=True, capture_output=True)
            times.append(time.perf_counter() - started)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    _, image = largest_fitting()
    size = len(image.to_bytes())
    print(f"image: {size} bytes of {EEPROM_SIZE} ({len(image.code)} bytes of code)")
    in_process = time_in_process(image, args.runs)
    print(f"download, in process (median of {args.runs}): {in_process:.3f} s")
    print(
        f"asictl download FILE.hex, whole process (median of {args.runs}): "
        f"{time_whole_process(image, args.runs):.3f} s"
    )


if __name__ == "__main__":
    main()
