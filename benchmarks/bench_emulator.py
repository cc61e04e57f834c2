"""Instructions per second of ``asictl emu`` and of ucsim's ``s51`` on the same images.

Two programs, each three nested DJNZ loops ending in ``SJMP $``, about 10 million
instructions. *straight*: the inner loop's body is MOV, ADD, ANL, MOVX (read and write
through DPTR), INC DPTR, CPL/MOV on a bit and RLC, without a jump. *branchy*: the same
kind of body with a ``JNB`` on the bit it complements and a ``JC`` on the carry inside,
as compiled IL looks (every ``JC`` over a network, every timer test). Each simulator runs
each as a whole process until the PC reaches the ``SJMP $``: ``asictl emu --until``, and
s51 with a breakpoint there and ``run``.

Execution time is the process's wall time minus that of the same command with nothing
to execute (``--max-instructions 0``; for s51 the script without ``run``), so Python's
and s51's start-up, loading the image and printing the result are not counted. Each
figure is the median of several runs, the four commands taking turns run after run (on
a busy machine a slow minute then falls on all of them); beside the wall time it gives
the CPU time (user + system) of each. Both simulators must report the same number of
machine cycles, or the comparison is void. Usage:

    python3 benchmarks/bench_emulator.py [--outer 45] [--runs 3] [--program branchy]
"""

from __future__ import annotations

import argparse
import json
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from intelhex import IntelHex

INNER, MIDDLE = 100, 200


def nested(body: str, outer: int, middle: int = MIDDLE, inner: int = INNER) -> tuple[bytes, int]:
    """Three nested DJNZ loops (R7, R6, R5) around ``body`` (hex) after ``MOV DPTR,#4000h``,
    ending in ``SJMP $``: the image and the address of that ``SJMP $``."""
    size = len(body) // 2
    code = bytes.fromhex(
        "904000"  # 0000      MOV   DPTR,#4000h
        f"7f{outer:02x}"  # 0003      MOV   R7,#outer
        f"7e{middle:02x}"  # 0005 L3:  MOV   R6,#middle
        f"7d{inner:02x}"  # 0007 L2:  MOV   R5,#inner
        f"{body}"  # 0009 L1:  the body
        f"dd{-(size + 2) & 0xFF:02x}"  # DJNZ  R5,L1
        f"de{-(size + 6) & 0xFF:02x}"  # DJNZ  R6,L2
        f"df{-(size + 10) & 0xFF:02x}"  # DJNZ  R7,L3
        "80fe"  # SJMP  $
    )
    return code, len(code) - 2


#: The straight program's inner loop body, from 0009.
STRAIGHT = (
    "ed"  # MOV   A,R5
    "2403"  # ADD   A,#3
    "547f"  # ANL   A,#7Fh
    "f0"  # MOVX  @DPTR,A
    "a3"  # INC   DPTR
    "e0"  # MOVX  A,@DPTR
    "b200"  # CPL   20h.0
    "a200"  # MOV   C,20h.0
    "33"  # RLC   A
    "f530"  # MOV   30h,A
)
#: The branchy one's: it takes its ``JNB`` every other pass and its ``JC`` when RLC
#: shifts a one out.
BRANCHY = (
    "ed"  # 0009       MOV   A,R5
    "2403"  # 000A       ADD   A,#3
    "f0"  # 000C       MOVX  @DPTR,A
    "a3"  # 000D       INC   DPTR
    "b200"  # 000E       CPL   20h.0
    "300004"  # 0010       JNB   20h.0,SKIP
    "e0"  # 0013       MOVX  A,@DPTR
    "547f"  # 0014       ANL   A,#7Fh
    "d3"  # 0016       SETB  C
    "33"  # 0017 SKIP: RLC   A
    "4002"  # 0018       JC    ODD
    "f530"  # 001A       MOV   30h,A
)  # 001C ODD: DJNZ R5,L1


def straight(outer: int) -> tuple[bytes, int]:
    return nested(STRAIGHT, outer)


def branchy(outer: int) -> tuple[bytes, int]:
    return nested(BRANCHY, outer)


PROGRAMS = {"straight": straight, "branchy": branchy}


def timed(command: list[str]) -> tuple[float, float, str]:
    """Wall and CPU seconds (user + system) of one run of ``command``, and its output."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, check=True, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    return wall, cpu, done.stdout


def interleaved(commands: list[list[str]], runs: int) -> list[tuple[float, float, str]]:
    """Median wall and CPU seconds of each command and its last output, the commands
    taking turns round after round, so that a busy moment of the machine falls on all
    of them alike."""
    samples: list[list[tuple[float, float, str]]] = [[] for _ in commands]
    for _ in range(runs):
        for command, taken in zip(commands, samples, strict=True):
            taken.append(timed(command))
    return [
        (statistics.median(s[0] for s in taken), statistics.median(s[1] for s in taken),
         taken[-1][2])
        for taken in samples
    ]


def compare(s51: str, code: bytes, end: int, runs: int) -> None:
    """Both simulators on one image, taking turns; the figures and their ratio."""
    with tempfile.TemporaryDirectory() as tmp:
        image = Path(tmp) / "bench.hex"
        hex_file = IntelHex()
        hex_file.frombytes(code)
        hex_file.write_hex_file(str(image))
        emu = [sys.executable, "-m", "asictl", "emu", str(image), "--max-instructions"]
        load = f'file "{image}"\nbreak {hex(end)}\n'
        idle, busy = Path(tmp) / "idle.cmd", Path(tmp) / "run.cmd"
        idle.write_text(load + "quit\n")
        busy.write_text(load + "run\nstate\nquit\n")
        s51_command = [s51, "-q", "-t", "8052", "-C"]
        (ours_idle, ours_idle_cpu, _), (ours, ours_cpu, state_text), \
            (theirs_idle, theirs_idle_cpu, _), (theirs, theirs_cpu, output) = interleaved(
                [[*emu, "0"], [*emu, "100000000", "--until", hex(end)],
                 [*s51_command, str(idle)], [*s51_command, str(busy)]], runs)
    state = json.loads(state_text)
    if state["pc"] != end:
        sys.exit(f"asictl emu stopped at {state['pc']:04X}h, not at the end {end:04X}h")
    if f"PC= 0x{end:06x}" not in output:
        sys.exit(f"s51 did not stop at {end:04X}h:\n{output[-2000:]}")
    clocks = re.search(r"since last reset= [\d.]+ sec \((\d+) clks\)", output)
    host = re.search(r"Host usage: ([\d.]+) sec", output)
    assert clocks and host, output[-2000:]
    instructions, cycles = state["instructions"], state["cycles"]
    if int(clocks.group(1)) // 12 != cycles:
        sys.exit(f"cycle counts differ: asictl {cycles}, s51 {int(clocks.group(1)) // 12}")
    ours, theirs = ours - ours_idle, theirs - theirs_idle
    ours_cpu, theirs_cpu = ours_cpu - ours_idle_cpu, theirs_cpu - theirs_idle_cpu
    ours_mips, theirs_mips = instructions / ours / 1e6, instructions / theirs / 1e6
    print(f"program: {instructions:,} instructions, {cycles:,} machine cycles (both agree)")
    print(f"asictl emu: {ours:.2f} s  {ours_mips:.2f} M instructions/s  (CPU {ours_cpu:.2f} s)")
    print(
        f"s51:        {theirs:.2f} s  {theirs_mips:.2f} M instructions/s  (CPU {theirs_cpu:.2f} s;"
        f" s51's own host time: {float(host.group(1)):.2f} s)"
    )
    print(f"ratio asictl/s51: {ours_mips / theirs_mips:.2f} wall, {theirs_cpu / ours_cpu:.2f} CPU"
          f" (medians of {runs} interleaved runs each)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--outer", type=int, default=45, help="outer loop count (1-255)")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--program", choices=sorted(PROGRAMS), action="append",
                        help="the program(s) to run (default: both)")
    args = parser.parse_args()
    s51 = shutil.which("s51") or sys.exit("s51 not found: apt-get install sdcc-ucsim")
    for name in args.program or PROGRAMS:
        print(f"== {name}")
        compare(s51, *PROGRAMS[name](args.outer), args.runs)


if __name__ == "__main__":
    main()
