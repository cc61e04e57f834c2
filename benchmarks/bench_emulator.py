"""Instructions per second of ``asictl emu`` and of ucsim's ``s51`` on the same image.

The program is three nested DJNZ loops around a body of MOV, ADD, ANL, MOVX (read and
write through DPTR), INC DPTR, CPL/MOV on a bit and RLC: about 10 million instructions,
ending in ``SJMP $``. Each simulator runs it as a whole process until the PC reaches the
``SJMP $``: ``asictl emu --until``, and s51 with a breakpoint there and ``run``.

Execution time is the process's wall time minus that of the same command with nothing
to execute (``--max-instructions 0``; for s51 the script without ``run``), so Python's
and s51's start-up, loading the image and printing the result are not counted. Each
figure is the median of several runs. Both simulators must report the same number of
machine cycles, or the comparison is void. Usage:

    python3 benchmarks/bench_emulator.py [--outer 45] [--runs 3]
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from intelhex import IntelHex

INNER, MIDDLE = 100, 200


def program(outer: int) -> tuple[bytes, int]:
    """The benchmark image and the address of its final ``SJMP $``."""
    code = bytes.fromhex(
        "904000"  # 0000      MOV   DPTR,#4000h
        f"7f{outer:02x}"  # 0003      MOV   R7,#outer
        f"7e{MIDDLE:02x}"  # 0005 L3:  MOV   R6,#MIDDLE
        f"7d{INNER:02x}"  # 0007 L2:  MOV   R5,#INNER
        "ed"  # 0009 L1:  MOV   A,R5
        "2403"  # 000A      ADD   A,#3
        "547f"  # 000C      ANL   A,#7Fh
        "f0"  # 000E      MOVX  @DPTR,A
        "a3"  # 000F      INC   DPTR
        "e0"  # 0010      MOVX  A,@DPTR
        "b200"  # 0011      CPL   20h.0
        "a200"  # 0013      MOV   C,20h.0
        "33"  # 0015      RLC   A
        "f530"  # 0016      MOV   30h,A
        "ddef"  # 0018      DJNZ  R5,L1
        "deeb"  # 001A      DJNZ  R6,L2
        "dfe7"  # 001C      DJNZ  R7,L3
        "80fe"  # 001E      SJMP  $
    )
    return code, len(code) - 2


def wall_time(command: list[str], runs: int) -> tuple[float, str]:
    """Median wall time of ``command`` and the output of its last run."""
    samples, output = [], ""
    for _ in range(runs):
        start = time.perf_counter()
        done = subprocess.run(command, check=True, capture_output=True, text=True)
        samples.append(time.perf_counter() - start)
        output = done.stdout
    return statistics.median(samples), output


def measure_asictl(image: Path, end: int, runs: int) -> tuple[float, int, int]:
    """Execution seconds, instructions and machine cycles of ``asictl emu``."""
    command = [sys.executable, "-m", "asictl", "emu", str(image), "--max-instructions"]
    overhead, _ = wall_time([*command, "0"], runs)
    total, output = wall_time([*command, "100000000", "--until", hex(end)], runs)
    state = json.loads(output)
    if state["pc"] != end:
        sys.exit(f"asictl emu stopped at {state['pc']:04X}h, not at the end {end:04X}h")
    return total - overhead, state["instructions"], state["cycles"]


def measure_s51(s51: str, image: Path, end: int, runs: int) -> tuple[float, int, float]:
    """Execution seconds, machine cycles and s51's own reported host time."""
    script = image.with_suffix(".cmd")
    load = f'file "{image}"\nbreak {hex(end)}\n'
    script.write_text(load + "quit\n")
    overhead, _ = wall_time([s51, "-q", "-t", "8052", "-C", str(script)], runs)
    script.write_text(load + "run\nstate\nquit\n")
    total, output = wall_time([s51, "-q", "-t", "8052", "-C", str(script)], runs)
    if f"PC= 0x{end:06x}" not in output:
        sys.exit(f"s51 did not stop at {end:04X}h:\n{output[-2000:]}")
    clocks = int(re.search(r"since last reset= [\d.]+ sec \((\d+) clks\)", output).group(1))
    host = float(re.search(r"Host usage: ([\d.]+) sec", output).group(1))
    return total - overhead, clocks // 12, host


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--outer", type=int, default=45, help="outer loop count (1-255)")
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    s51 = shutil.which("s51") or sys.exit("s51 not found: apt-get install sdcc-ucsim")
    code, end = program(args.outer)
    with tempfile.TemporaryDirectory() as tmp:
        image = Path(tmp) / "bench.hex"
        hex_file = IntelHex()
        hex_file.frombytes(code)
        hex_file.write_hex_file(str(image))
        ours, instructions, cycles = measure_asictl(image, end, args.runs)
        theirs, s51_cycles, s51_host = measure_s51(s51, image, end, args.runs)
    if s51_cycles != cycles:
        sys.exit(f"cycle counts differ: asictl {cycles}, s51 {s51_cycles}")
    ours_mips, theirs_mips = instructions / ours / 1e6, instructions / theirs / 1e6
    print(f"program: {instructions:,} instructions, {cycles:,} machine cycles (both agree)")
    print(f"asictl emu: {ours:.2f} s  {ours_mips:.2f} M instructions/s")
    print(
        f"s51:        {theirs:.2f} s  {theirs_mips:.2f} M instructions/s "
        f"(s51's own host time: {s51_host:.2f} s)"
    )
    print(f"ratio asictl/s51: {ours_mips / theirs_mips:.2f} (median of {args.runs} runs each)")


if __name__ == "__main__":
    main()
