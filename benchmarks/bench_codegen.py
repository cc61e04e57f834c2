"""Code size and machine cycles of compiled programs.

For a generated 200-line bit-logic program (A/AN/O/ON/= on I, Q and F) it reports the
bytes and machine cycles per bit-logic IL instruction (target: at most 4 bytes and 6
cycles on average), and code size and cycles per scan for every program in demos/.
Cycles are counted by running one scan on the emulator. Usage:

    python3 benchmarks/bench_codegen.py [--lines 200] [--seed 1]
"""

from __future__ import annotations

import argparse
import random
from pathlib import Path

from asictl.codegen8051.compiler import compile_program
from asictl.il import ast
from asictl.il.checks import check_source
from asictl.runtime.program_map import LoadedProgram
from asictl.runtime.runner import ProgramRunner
from asictl.source import from_string, read_source

ROOT = Path(__file__).resolve().parent.parent


def bit_logic_program(lines: int, seed: int) -> str:
    """Networks of 2-5 A/AN/O/ON on inputs, outputs and flags, each ending in '='."""
    rng = random.Random(seed)

    def operand(writable: bool = False) -> str:
        mark = rng.choice(["Q", "F"] if writable else ["I", "I", "Q", "F"])
        if mark == "F":
            return f"F {rng.randrange(0, 32)}.{rng.randrange(8)}"
        return f"{mark} {rng.randrange(1, 32)}.{rng.randrange(4)}"

    out = ["[PROGRAM]"]
    count = 0
    while count < lines:
        terms = rng.randint(2, 5)
        for i in range(terms):
            op = rng.choice(["A", "AN"]) if i == 0 else rng.choice(["A", "AN", "O", "ON"])
            out.append(f"    {op} {operand()}")
        out.append(f"    = {operand(writable=True)}")
        out.append("***")
        count += terms + 1
    return "\n".join(out) + "\n"


def measure(text: str, name: str) -> tuple[int, int, int, int, int]:
    """(code bytes, cycles per scan, bit-logic instructions, their bytes, their cycles)."""
    result = check_source(from_string(name, text))
    if result.has_errors:
        raise SystemExit(f"{name}: {result.diagnostics[0]}")
    compiled = compile_program(result.program)
    logic_lines = {
        (s.span.file, s.span.line)
        for m in result.program.modules()
        for section in m.sections_of(ast.ProgramSection)
        for s in section.statements
        if isinstance(s, ast.Logic)
        or (isinstance(s, ast.Store) and s.op is ast.StoreOp.ASSIGN)
    }
    logic_bytes = logic_cycles = 0
    for entry in compiled.assembly.listing:
        generated = compiled.lines[entry.span.line - 1]
        if generated.span and (generated.span.file, generated.span.line) in logic_lines:
            logic_bytes += len(entry.data)
            logic_cycles += entry.cycles or 0
    runner = ProgramRunner(LoadedProgram(compiled.code, compiled.pmap, compiled.entry_points))
    runner.cycle()
    return len(compiled.code), runner.last_cycles, len(logic_lines), logic_bytes, logic_cycles


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lines", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    text = bit_logic_program(args.lines, args.seed)
    size, scan, n, logic_bytes, logic_cycles = measure(text, "bitlogic.asi")
    print(f"bit-logic program: {n} A/AN/O/ON/= instructions, {size} bytes of code, "
          f"{scan} machine cycles per scan")
    print(f"  per instruction: {logic_bytes / n:.2f} bytes (target <= 4), "
          f"{logic_cycles / n:.2f} machine cycles (target <= 6)")
    print()
    print(f"{'demo':<16} {'code bytes':>10} {'cycles/scan':>12}")
    for demo in sorted((ROOT / "demos").glob("*.asi")):
        size, scan, *_ = measure(read_source(demo).text, str(demo))  # its blocks beside it
        print(f"{demo.name:<16} {size:>10} {scan:>12}")


if __name__ == "__main__":
    main()
