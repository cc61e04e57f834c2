"""Simulation speed of the emulated PC2 board: wall time per hour of master time.

Each case powers up a board whose EEPROM holds a compiled program (start flag set,
configuration projected), lets ``--minutes`` of master time pass and scales the wall
time to an hour. The cases are the table in docs/master.md. Usage:

    python3 benchmarks/bench_board.py [--minutes 6]
"""

from __future__ import annotations

import argparse
import time

from asictl.board.asi import AsiBus, Slave
from asictl.board.board import Pc2Board
from asictl.build import build_image
from asictl.codegen8051.compiler import compile_program
from asictl.il.checks import check_source
from asictl.platform.master import ControlFlag
from asictl.platform.pc2 import ControlState
from asictl.source import from_string

FOLLOW = "[PROGRAM]\n        A I 1.0\n        = Q 2.0\n"
BLINK = """[PROGRAM]
        A   T 0
        JC  = end
        N
        L   KT 500
        S   T 0
***
        AN  Q 2.0
        =   Q 2.0
end:    BE
"""
#: the same blinker, also copying its timer's remaining time to a flag word: the master
#: must then count every tick (the image says that the program reads the time)
BLINK_READ = BLINK.replace("end:    BE", "***\n        L   T 0\n        T   FW 10\nend:    BE")
TOGGLE = "[PROGRAM]\n        AN Q 2.0\n        = Q 2.0\n"
CASES = [
    ("follows inputs (idle), 2 slaves", FOLLOW, 2),
    ("500 ms blinker, 2 slaves", BLINK, 2),
    ("500 ms blinker reading its timer, 2 slaves", BLINK_READ, 2),
    ("output toggling every cycle, 31 slaves", TOGGLE, 31),
    ("output toggling every cycle, 2 slaves", TOGGLE, 2),
]


def running_board(text: str, slaves: int) -> Pc2Board:
    """A board powered up with ``text`` in its EEPROM and ``slaves`` slaves projected."""
    setup = "".join(f"{a}: bbbb, 0\n" for a in range(1, slaves + 1))
    result = check_source(from_string("bench.asi", f"[SETUP]\n{setup}{text}"))
    assert not result.has_errors, result.diagnostics
    image = build_image(compile_program(result.program))
    bus = AsiBus([Slave(a, 0x7, 0x0) for a in range(1, slaves + 1)])
    state = Pc2Board(bus=bus).nonvolatile()
    configuration = image.configuration
    state.update(
        eeprom=image.to_bytes().hex(),
        control_flags=image.flags | ControlFlag.START,
        configuration_mode=False,
        lps=configuration.projected(),
        pcd=configuration.pcd.hex(),
        pp=configuration.pp.hex(),
    )
    board = Pc2Board.from_nonvolatile(state)
    board.advance(50)
    assert board.control_state is ControlState.RUNNING, board.stop_message
    return board


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=6.0)
    args = parser.parse_args()
    for name, text, slaves in CASES:
        board = running_board(text, slaves)
        runner = board.program
        start_cycles, start = runner.cpu.cycles, time.perf_counter()
        cpu_start = time.process_time()
        board.advance(args.minutes * 60_000)
        wall = time.perf_counter() - start
        cpu = time.process_time() - cpu_start
        scale = 60 / args.minutes
        ran = (runner.cpu.cycles - start_cycles) // max(runner.last_cycles, 1)
        print(
            f"{name:42s} {wall * scale:7.1f} s per hour, "
            f"{ran * scale:11,.0f} program cycles run per hour, {ran / wall:9,.0f} per second, "
            f"{ran / max(cpu, 1e-9):9,.0f} per CPU second"
        )


if __name__ == "__main__":
    main()
