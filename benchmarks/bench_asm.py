"""Time ``asictl asm`` on a generated program of about 16 KB of 8051 code.

Timed as a whole process (Python start-up included), with listing and symbol files,
as a user or the IL compiler's build sees it: the median of several runs after one
warm-up run. Usage:

    python3 benchmarks/bench_asm.py [--kbytes 16] [--runs 7]
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

from bench_check import timed

BLOCK_BYTES = 31  # code bytes of one generated block


def generate(kbytes: int) -> str:
    """Control-style code: loops, bit tests, calls back and forth, and data tables."""
    blocks = kbytes * 1024 // BLOCK_BYTES
    out = ["counter equ 30h", "flag    bit 20h.0", "        org 0"]
    for n in range(blocks):
        out += [
            f"blk{n}:  mov     a,counter      ; block {n}",
            f"        add     a,#{n % 256}",
            "        mov     r0,#40h",
            "        movx    @dptr,a",
            f"        jnb     acc.{n % 8},skip{n}",
            f"        lcall   blk{(n * 7) % blocks}",
            f"        setb    p1.{n % 8}",
            f"skip{n}: djnz    r7,blk{n}",
            f"        cjne    a,#{n % 256},skip{n}",
            f"        mov     dptr,#table{n}",
            "        movc    a,@a+dptr",
            "        cpl     flag",
            "        ret",
            f"table{n}: db      1,2,3,'x'",
        ]
    return "\n".join(out) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kbytes", type=int, default=16)
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    asictl = shutil.which("asictl") or sys.exit("asictl is not installed (pip install -e .)")
    with tempfile.TemporaryDirectory() as tmp:
        program = Path(tmp) / "big.a51"
        program.write_text(generate(args.kbytes))
        lines = program.read_text().count("\n")
        command = [asictl, "asm", str(program), "--listing", str(Path(tmp) / "big.lst"),
                   "--symbols", str(Path(tmp) / "big.sym")]
        seconds = timed(command, args.runs)
        if not (Path(tmp) / "big.hex").exists():
            sys.exit("asictl asm found errors in the generated program")
        size = sum(int(line[1:3], 16) for line in (Path(tmp) / "big.hex").read_text().split())
    print(f"asictl asm, {lines} lines, {size} bytes: {seconds:.3f} s "
          f"(median of {args.runs}; target < 2.0 s)")


if __name__ == "__main__":
    main()
