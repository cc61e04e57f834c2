"""Which jump keeps an 8051 program looping.

A program cut off by a time-out is somewhere inside its endless loop; the address people
need is that of the jump closing the loop. A detached copy of the machine (same memories
and registers, no traps, no devices) runs on a little, and the last backward jump it
takes is that jump. The machine itself is not touched.
"""

from __future__ import annotations

import contextlib

from asictl.mcs51.bus import Bus
from asictl.mcs51.emulator import Emulator, EmulatorError
from asictl.mcs51.isa import OPCODES

_JUMPS = frozenset({"AJMP", "LJMP", "SJMP", "JMP", "JC", "JNC", "JZ", "JNZ", "JB", "JNB",
                    "JBC", "CJNE", "DJNZ"})
#: How many instructions the copy runs.
SEARCH = 20_000


def looping_jumps(cpu: Emulator, instructions: int = SEARCH) -> list[int]:
    """The addresses of the backward jumps a copy of ``cpu`` takes, last one last."""
    copy = detached_copy(cpu)
    jumps: list[int] = []

    def watch(emulator: Emulator, address: int) -> None:
        info = OPCODES[emulator.code[address]]
        if info is not None and info.mnemonic in _JUMPS and emulator.pc <= address:
            jumps.append(address)

    with contextlib.suppress(EmulatorError):  # the copy may run into an undefined opcode
        copy.run(max_instructions=instructions, trace=watch)
    return jumps


def detached_copy(cpu: Emulator) -> Emulator:
    """A copy of the machine: same memories and registers, no traps, plain RAM."""
    xdata = Bus()
    xdata.ram[:] = cpu.xdata.ram
    copy = Emulator(xdata=xdata, translate=False)
    copy.code.load(0, bytes(cpu.code))
    copy.iram[:] = cpu.iram
    copy.sfr[:] = cpu.sfr
    copy.pc = cpu.pc
    return copy
