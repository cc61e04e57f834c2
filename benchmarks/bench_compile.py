"""Time ``asictl compile`` on a generated IL program whose image fills the 16 KB EEPROM.

The program is bench_check's (bit-logic networks, byte arithmetic, timers, counters and
jumps), as long as still fits: the most lines whose image (code and program map; the
source is left out once it no longer fits) stays within 16384 bytes, found in process. The
compile is then timed as a whole process (Python start-up included), with the listing,
as a user sees it: the median of several runs after one warm-up run. The code generator's
own part, ``compile_program`` on the checked program (allocation, instruction selection,
jump relaxation and assembly), is timed in process as CPU time, which hardly depends on
what else the machine runs. Both measure the asictl this Python imports (so
``PYTHONPATH=src`` measures a checkout). Usage:

    python3 benchmarks/bench_compile.py [--runs 7]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

from bench_check import generate, timed_with_cpu

from asictl.build import build_image
from asictl.codegen8051.compiler import compile_program
from asictl.diagnostics import DiagnosticError
from asictl.il.checks import check_source
from asictl.il.loader import Program
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


def code_generation_seconds(program: Program, runs: int) -> float:
    """Median CPU time of ``compile_program`` on a checked program, after a warm-up."""
    compile_program(program)
    times = []
    for _ in range(runs):
        start = time.process_time()
        compile_program(program)
        times.append(time.process_time() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    size, image = largest_fitting()
    text = generate(size)
    checked = check_source(from_string("big.asi", text)).program
    assert checked is not None
    generation = code_generation_seconds(checked, args.runs)
    with tempfile.TemporaryDirectory() as tmp:
        program = Path(tmp) / "big.asi"
        program.write_text(text)
        lines = text.count("\n")
        command = [sys.executable, "-m", "asictl", "compile", str(program),
                   "--listing", str(Path(tmp) / "big.lst")]
        seconds, cpu = timed_with_cpu(command, args.runs)
    print(
        f"asictl compile, {lines} lines: code {len(image.code)} bytes, "
        f"image {len(image.to_bytes())} of {EEPROM_SIZE} bytes: {seconds:.3f} s, "
        f"CPU {cpu:.3f} s (median of {args.runs}; target < 2 s); "
        f"compile_program {generation:.3f} s CPU (median of {args.runs})"
    )


if __name__ == "__main__":
    main()
