"""Where in the IL source a stopped 8051 is.

The line map names the line of an address. A stop inside a function block is named with
its block line and the lines that called it, read from the return addresses on the
8051's stack (the compiled code calls blocks and helpers with LCALL, and the firmware
entered the program with the cycle-end address pushed first, docs/runtime.md). A cycle
time-out happens wherever the endless loop happened to be; the line people need is the
jump that closes the loop, which the firmware finds (``runtime.runner``) and leaves in
the communication memory for the host.
"""

from __future__ import annotations

from asictl.mcs51.emulator import Emulator
from asictl.mcs51.isa import SFRS
from asictl.runtime import layout
from asictl.runtime.line_map import LineMap, SourceLine

_SP = SFRS["SP"]


def call_chain(cpu: Emulator, line_map: LineMap) -> list[SourceLine]:
    """The lines that called the code running now (outermost first), from the stack."""
    chain = []
    first = layout.STACK_START + 4  # above the cycle-end address the firmware pushed
    for top in range(first, cpu.sfr[_SP] + 1, 2):
        returns_to = cpu.iram[top - 1] | cpu.iram[top] << 8
        line = line_map.line_at(returns_to - 1)  # the call's last byte: the calling line
        if line is not None:
            chain.append(line)
    return chain


def current_line(cpu: Emulator, line_map: LineMap) -> SourceLine | None:
    """The line at the PC, or, in code of no line (a helper, a firmware block), the line
    that called it."""
    line = line_map.line_at(cpu.pc)
    if line is None:
        chain = call_chain(cpu, line_map)
        return chain[-1] if chain else None
    return line


def describe(line: SourceLine | None, cpu: Emulator, line_map: LineMap) -> str:
    """``count3.fb:5 (called from fb.asi:38)``; empty when the line is not known."""
    if line is None:
        return ""
    callers = [c for c in call_chain(cpu, line_map) if c != line]
    if not callers:
        return str(line)
    return f"{line} (called from {', '.join(str(c) for c in reversed(callers))})"
