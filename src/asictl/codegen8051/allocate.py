"""Where a program's data lives: the compiler's memory allocation.

Bit logic is what control programs spend their time on, and the 8051 does it fastest on
the 128 bits of internal RAM 20h-2Fh (``ANL C,bit``: 2 bytes, 2 machine cycles). So the
process-image bytes a program uses (input, old input, output, flag bytes, timer-status
groups) are "cells" that the compiler places per program: the most used bit operands in
the bit-addressable bytes, the rest in directly addressable RAM, and only what does not
fit in external RAM. The firmware learns the placement from the program map in the image
and copies inputs in and outputs and flags out around each cycle.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import assert_never

from asictl.il import ast
from asictl.il.ast import key
from asictl.il.language import COUNTER_FLAG_BASE, MAPPED_COUNTERS
from asictl.il.loader import Program
from asictl.runtime import layout
from asictl.runtime.program_map import (
    Cell,
    CellKind,
    Location,
    ProgramMap,
    Space,
    Variable,
    timer_status,
)

K = ast.OperandKind
_IMAGE_CELLS = {K.I: CellKind.I, K.I2: CellKind.I2, K.Q: CellKind.Q}
_BYTE_CELLS = {K.IB: CellKind.I, K.I2B: CellKind.I2, K.QB: CellKind.Q}


def bit_cell(operand: ast.Operand) -> tuple[Cell, int]:
    """The cell and bit (0-7) of an I/I2/Q/F bit operand: slave 2k+1 is the high nibble."""
    if operand.kind is K.F:
        return (CellKind.F, operand.address), operand.bit
    cell = (_IMAGE_CELLS[operand.kind], operand.address >> 1)
    return cell, (operand.address & 1) * 4 + operand.bit


def byte_cell(operand: ast.Operand) -> Cell:
    """The cell of an IB/I2B/QB/FY byte operand."""
    if operand.kind is K.FY:
        return CellKind.F, operand.address
    return _BYTE_CELLS[operand.kind], operand.address >> 1


@dataclass
class _Usage:
    bit_uses: Counter[Cell] = field(default_factory=Counter)
    byte_uses: Counter[Cell] = field(default_factory=Counter)
    timers: set[int] = field(default_factory=set)
    #: the timers whose remaining time the code reads (``L T n``)
    read_timers: set[int] = field(default_factory=set)
    counters: set[int] = field(default_factory=set)

    def bit(self, cell: Cell) -> None:
        self.bit_uses[cell] += 1

    def byte(self, cell: Cell) -> None:
        self.byte_uses[cell] += 1


def _usage(program: Program) -> _Usage:
    """How often the program's code uses each cell as bits and as bytes, and which timers
    and counters it has. A [PROGRAM] statement on a timer (status bit or word) uses its
    status byte; a gating line only its status bit. Which timers' remaining time it
    reads is noted for the image (``ProgramMap.unread_timers``)."""
    usage = _Usage()
    for module in program.modules():
        for node in module.code():
            statement = not isinstance(node, ast.GatingLine)
            for operand, access in ast.operands(node):
                n = operand.address
                match operand.kind:
                    case K.I | K.I2 | K.Q | K.F:
                        usage.bit(bit_cell(operand)[0])
                    case K.IB | K.I2B | K.QB | K.FY:
                        usage.byte(byte_cell(operand))
                    case K.FW:
                        usage.byte((CellKind.F, n))
                        usage.byte((CellKind.F, n + 1))
                    case K.T:
                        usage.timers.add(n)
                        if operand.width is ast.Width.BIT:
                            usage.bit(timer_status(n)[0])
                        if statement:
                            usage.byte(timer_status(n)[0])
                        if operand.width is not ast.Width.BIT and access is not ast.Access.WRITE:
                            usage.read_timers.add(n)
                    case K.C:
                        usage.counters.add(n)
                    case K.PSEG | K.VAR | K.KT | K.KC | K.KB | K.KW | K.KP:
                        pass  # PSeg and variables have places of their own
                    case _:
                        assert_never(operand.kind)
    return usage


def allocate(program: Program, *, map_counters: bool) -> ProgramMap:
    """Place every cell, timer, counter and variable the program uses."""
    usage = _usage(program)
    result = ProgramMap(map_counters=map_counters)
    pinned = (
        {(CellKind.F, COUNTER_FLAG_BASE + i) for i in range(2 * MAPPED_COUNTERS)}
        if map_counters
        else set()
    )
    used = [c for c in {*usage.bit_uses, *usage.byte_uses} if c not in pinned]

    def weight(cell: Cell) -> tuple[int, int, Cell]:
        return (-usage.bit_uses[cell], -usage.byte_uses[cell], cell)

    bit_pool = list(layout.BIT_POOL)
    direct_pool = list(layout.DIRECT_POOL)
    for cell in sorted((c for c in used if usage.bit_uses[c]), key=weight):
        if not bit_pool:
            break
        result.cells[cell] = Location(Space.IRAM, bit_pool.pop(0))
    for cell in sorted((c for c in used if c not in result.cells), key=weight):
        if not direct_pool:
            break
        result.cells[cell] = Location(Space.IRAM, direct_pool.pop(0))

    cursor = layout.DATA_BASE

    def take(size: int) -> int:
        nonlocal cursor
        address, cursor = cursor, cursor + size
        return address

    result.pseg = take(16)
    for n in sorted(usage.timers):
        result.timers[n] = take(2)
    for n in sorted(usage.counters):
        if map_counters and n < MAPPED_COUNTERS:
            result.counters[n] = layout.FLAGS_BASE + COUNTER_FLAG_BASE + 2 * n
        else:
            result.counters[n] = take(2)
    for module in program.modules():
        for section in module.sections_of(ast.DeclSection):
            for decl in section.declarations:
                if not isinstance(decl, ast.VarDecl):
                    continue
                name = key(decl.name)
                if name not in result.variables:
                    result.variables[name] = Variable(decl.name, take(decl.size), decl.size)
    # cells that did not fit: flags stay at home in the communication memory
    for cell in sorted(c for c in used if c not in result.cells and c[0] is not CellKind.F):
        result.cells[cell] = Location(Space.XDATA, take(1))
    result.data_end = cursor
    # hand-written assembly may read any timer's remaining time
    if not any(module.has_assembly() for module in program.modules()):
        result.unread_timers = usage.timers - usage.read_timers
    return result
