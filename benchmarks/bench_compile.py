"""Time ``asictl compile`` on a generated IL program whose image fills the 16 KB EEPROM.

The program is bench_check's (bit-logic networks, byte arithmetic, timers, counters and
jumps), as long as still fits: the most lines whose image (code and program map; the
source is left out once it no longer fits) stays within 16384 bytes, found in process. The
compile is then timed as a whole process (Python start-up included), with the listing,
as a user sees it: the median of several runs after one warm-up run. Usage:

    python3 benchmarks/bench_compile.py [--runs 7]
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

from bench_check import generate, timed

from asictl.build import build_image
from asictl.codegen8051.compiler import compile_program
from asictl.diagnostics import DiagnosticError
from asictl.il.checks import check_source
from asictl.image.eeprom import ImageError, ProgramImage
from asictl.platform.master import EEPROM_SIZE
from asictl.source import from_string


def image_of(lines: int) -> ProgramImage | None:
    """The image of a generated program of about this many lines; None if it does not fit."""
    result = check_source(from_string("big.asi", generate(lines)))
    if result.diagnostics:
        sys.exit(f"the generated program is not clean: {result.diagnostics[:3]}")
    try:
        return build_image(compile_program(result.program))
    except (ImageError, DiagnosticError):
        return None


def largest_fitting() -> tuple[int, ProgramImage]:
    """Binary search for the longest program whose image fits, to within one network."""
    low, high = 100, 200
    while image_of(high) is not None:
        low, high = high, high * 2
    while high - low > 10:
        middle = (low + high) // 2
        if image_of(middle) is None:
            high = middle
        else:
            low = middle
    image = image_of(low)
    assert image is not None
    return low, image


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    asictl = shutil.which("asictl") or sys.exit("asictl is not installed (pip install -e .)")
    size, image = largest_fitting()
    with tempfile.TemporaryDirectory() as tmp:
        program = Path(tmp) / "big.asi"
        program.write_text(generate(size))
        lines = program.read_text().count("\n")
        command = [asictl, "compile", str(program), "--listing", str(Path(tmp) / "big.lst")]
        seconds = timed(command, args.runs)
    print(
        f"asictl compile, {lines} lines: code {len(image.code)} bytes, "
        f"image {len(image.to_bytes())} of {EEPROM_SIZE} bytes: {seconds:.3f} s "
        f"(median of {args.runs}; target < 2 s)"
    )


if __name__ == "__main__":
    main()
