"""Operands as the running program sees them, read from the 8051's memory.

Between cycles this is what a scenario reads; inside a cycle (at a breakpoint, in a
per-line trace) the program works on its cells: its input image of this cycle, the flag
bytes it copied into internal RAM, the outputs it has written so far. The IL registers
are where docs/runtime.md puts them: the single-bit register in the carry, ACCU1 in
R6/R7, ACCU2 in R4/R5 of register bank 0.
"""

from __future__ import annotations

from collections.abc import Callable

from asictl.board.board import Pc2Board
from asictl.il import ast
from asictl.mcs51.isa import SFRS
from asictl.observe.operands import CounterValue, Operand, TimerValue
from asictl.platform import pc2
from asictl.platform.master import COUNTER_FLAG_BASE, MAPPED_COUNTERS, TICK_MS
from asictl.runtime import layout
from asictl.runtime.program_map import CellKind
from asictl.runtime.runner import ProgramRunner

_PSW = SFRS["PSW"]
_CARRY = 0x80
_CELL = {ast.BitArea.I: CellKind.I, ast.BitArea.I2: CellKind.I2, ast.BitArea.Q: CellKind.Q}
_BYTE_CELL = {ast.ByteArea.IB: CellKind.I, ast.ByteArea.I2B: CellKind.I2,
              ast.ByteArea.QB: CellKind.Q}


class ProgramView:
    """Reads a runner's memory; ``outside(operand)`` answers for slave data the program
    keeps no cell for (it never uses it)."""

    def __init__(self, runner: ProgramRunner, outside: Callable[[Operand], int]) -> None:
        self.runner = runner
        self.outside = outside

    @property
    def rlo(self) -> int:
        return int(bool(self.runner.cpu.sfr[_PSW] & _CARRY))

    @property
    def accu1(self) -> int:
        iram = self.runner.cpu.iram
        return iram[layout.ACCU1_HI] << 8 | iram[layout.ACCU1_LO]

    @property
    def accu2(self) -> int:
        iram = self.runner.cpu.iram
        return iram[layout.ACCU2_HI] << 8 | iram[layout.ACCU2_LO]

    @property
    def constant(self) -> int:
        """The constant register: the last ``L KT``, ``L KC`` or ``L KP``."""
        iram = self.runner.cpu.iram
        return iram[layout.KREG_HI] << 8 | iram[layout.KREG_LO]

    def word(self, address: int) -> int:
        xdata = self.runner.cpu.xdata
        return xdata.read(address) | xdata.read(address + 1) << 8

    def counter(self, number: int) -> int | None:
        """Counter ``number``'s value; with map_counters, counters 0..14 are their flag
        bytes whether or not the program names them (the host may write them)."""
        pmap = self.runner.pmap
        address = pmap.counters.get(number)
        if address is None and pmap.map_counters and number < MAPPED_COUNTERS:
            address = layout.FLAGS_BASE + COUNTER_FLAG_BASE + 2 * number
        return None if address is None else self.word(address) & 0xFFF

    def timer_ms(self, number: int) -> int | None:
        address = self.runner.pmap.timers.get(number)
        return None if address is None else self.word(address) * TICK_MS

    def read(self, operand: Operand) -> int:
        runner, pmap = self.runner, self.runner.pmap
        xdata = runner.cpu.xdata
        match operand.node:
            case ast.ImageBit(area=ast.BitArea.F, address=a, bit=b):
                return runner.read(pmap.flag(a)) >> b & 1
            case ast.ImageByte(area=ast.ByteArea.FY, number=n):
                return runner.read(pmap.flag(n))
            case ast.ImageBit(area=area, address=a, bit=b):
                cell = pmap.cells.get((_CELL[area], a >> 1))
                if cell is None:
                    return self.outside(operand)
                return runner.read(cell) >> ((a & 1) * 4 + b) & 1
            case ast.ImageByte(area=ast.ByteArea.PSEG, number=n):
                return xdata.read(pmap.pseg + n)
            case ast.ImageByte(area=area, number=n):
                cell = pmap.cells.get((_BYTE_CELL[area], n >> 1))
                return self.outside(operand) if cell is None else runner.read(cell)
            case ast.TimerRef(number=n):
                return int(bool(self.timer_ms(n)))
            case ast.CounterRef(number=n):
                return int(bool(self.counter(n)))
            case CounterValue(number=n):
                return self.counter(n) or 0
            case TimerValue(number=n):
                return self.timer_ms(n) or 0
            case ast.VarBit(name=name, offset=o, bit=b):
                return xdata.read(pmap.variables[name.casefold()].address + o) >> b & 1
            case ast.VarByte(name=name, offset=o):
                return xdata.read(pmap.variables[name.casefold()].address + o)
        raise AssertionError(operand)


def read_on_board(board: Pc2Board, operand: Operand) -> int:
    """An operand's value on a board now, as the plant sees it: inputs as the slaves
    deliver them, outputs as the slaves receive them (0 while the program is stopped),
    flags from the communication memory, the rest from the program's memory."""
    node = operand.node
    match node:
        case ast.ImageBit(area=ast.BitArea.I, address=a, bit=b):
            return _slave_inputs(board, a) >> b & 1
        case ast.ImageByte(area=ast.ByteArea.IB, number=n):
            return _slave_inputs(board, n) | _slave_inputs(board, n + 1) << 4
        case ast.ImageBit(area=ast.BitArea.Q, address=a, bit=b):
            return board.outputs[a >> 1] >> ((a & 1) * 4 + b) & 1
        case ast.ImageByte(area=ast.ByteArea.QB, number=n):
            return board.outputs[n >> 1]
        case ast.ImageBit(area=ast.BitArea.F, address=a, bit=b):
            return board.dpram_byte(pc2.FLAGS + a) >> b & 1
        case ast.ImageByte(area=ast.ByteArea.FY, number=n):
            return board.dpram_byte(pc2.FLAGS + n)
    runner = board.program
    if runner is None:
        return 0
    return ProgramView(runner, lambda _: 0).read(operand)  # I2 without a cell reads 0


def host_write(board: Pc2Board, address: int, value: int) -> None:
    """As a host writes the communication memory: through the board's I/O registers."""
    board.io_write(pc2.PORT_PAGE, address >> 8)
    board.io_write(pc2.PORT_INDEX, address & 0xFF)
    board.io_write(pc2.PORT_DATA, value)


def wake(board: Pc2Board) -> None:
    """Make the master run its next cycle even if the program looked idle (it skips
    cycles that would repeat the last one): a host access, rewriting a byte of the
    download buffer with what it holds, counts as news and changes nothing."""
    host_write(board, pc2.PROGRAM_BUFFER, board.dpram_byte(pc2.PROGRAM_BUFFER))


def _slave_inputs(board: Pc2Board, address: int) -> int:
    slaves = board.bus.at(address)
    return slaves[0].inputs if slaves else 0
