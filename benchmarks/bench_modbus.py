"""Time a download of a full 16 KB image over Modbus TCP on loopback (target: < 5 s).

The image is bench_compile's largest that fits the EEPROM; the gateway is the emulated one
(``asictl.gateway.server``) on 127.0.0.1 with a port the OS picks, in front of a new
emulated board each run. It times the whole download procedure through ``ModbusTransport``:
configuration registers, 16-byte blocks with function 66, the read-back with function 67,
register 1009 with the reset bit, and reports the median of several runs.

Usage:

    python3 benchmarks/bench_modbus.py [--runs 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

from bench_compile import largest_fitting

from asictl.board.board import Pc2Board
from asictl.gateway.server import background_gateway
from asictl.gateway.slave import GatewaySlave
from asictl.host.transfer import StartMode, download
from asictl.host.transports.modbus import open_modbus
from asictl.host.transports.target import parse_target
from asictl.image.eeprom import ProgramImage
from asictl.platform.master import EEPROM_SIZE


def time_download(image: ProgramImage, runs: int) -> float:
    times = []
    for _ in range(runs):
        with background_gateway(GatewaySlave(Pc2Board())) as gateway:
            host, port = gateway.server.tcp_address
            with open_modbus(parse_target(f"tcp://{host}:{port}")) as transport:
                started = time.perf_counter()
                download(transport, image, start=StartMode.START)
                times.append(time.perf_counter() - started)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    _, image = largest_fitting()
    size = len(image.to_bytes())
    print(f"image: {size} bytes of {EEPROM_SIZE} ({len(image.code)} bytes of code)")
    print(f"download over Modbus TCP, loopback (median of {args.runs}): "
          f"{time_download(image, args.runs):.3f} s")


if __name__ == "__main__":
    main()
