"""Operands as the running program sees them, read from the 8051's memory.

Between cycles this is what a scenario reads; inside a cycle (at a breakpoint, in a
per-line trace) the program works on its cells: its input image of this cycle, the flag
bytes it copied into internal RAM, the outputs it has written so far. The IL registers
are where docs/runtime.md puts them: the single-bit register in the carry, ACCU1 in
R6/R7, ACCU2 in R4/R5 of register bank 0.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import assert_never

from asictl.board.board import Pc2Board
from asictl.il import ast
from asictl.mcs51.isa import SFRS
from asictl.observe.operands import Operand
from asictl.platform import pc2
from asictl.platform.master import COUNTER_FLAG_BASE, MAPPED_COUNTERS, TICK_MS
from asictl.runtime import layout
from asictl.runtime.program_map import CellKind
from asictl.runtime.runner import ProgramRunner

_PSW = SFRS["PSW"]
_CARRY = 0x80
K = ast.OperandKind
_CELL = {K.I: CellKind.I, K.I2: CellKind.I2, K.Q: CellKind.Q, K.IB: CellKind.I,
         K.I2B: CellKind.I2, K.QB: CellKind.Q}


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
        node = operand.node
        n, b = node.address, node.bit
        match node.kind:
            case K.F:
                return runner.read(pmap.flag(n)) >> b & 1
            case K.FY:
                return runner.read(pmap.flag(n))
            case K.I | K.I2 | K.Q:
                cell = pmap.cells.get((_CELL[node.kind], n >> 1))
                if cell is None:
                    return self.outside(operand)
                return _data_bits(runner.read(cell) >> (n & 1) * 4, b)
            case K.PSEG:
                return xdata.read(pmap.pseg + n)
            case K.IB | K.I2B | K.QB:
                cell = pmap.cells.get((_CELL[node.kind], n >> 1))
                return self.outside(operand) if cell is None else runner.read(cell)
            case K.T:
                ms = self.timer_ms(n)
                return (ms or 0) if node.width is ast.Width.WORD else int(bool(ms))
            case K.C:
                count = self.counter(n)
                return (count or 0) if node.width is ast.Width.WORD else int(bool(count))
            case K.VAR:
                byte = xdata.read(pmap.variables[node.name.casefold()].address + n)
                return byte if node.width is ast.Width.BYTE else byte >> b & 1
            case K.FW | K.KT | K.KC | K.KB | K.KW | K.KP:
                raise AssertionError(f"{operand} is not observed")
            case _:
                assert_never(node.kind)


def read_on_board(board: Pc2Board, operand: Operand) -> int:
    """An operand's value on a board now, as the plant sees it: inputs as the slaves
    deliver them, outputs as the program wrote them into the output image the master
    sends (0 while the program is stopped; with data exchange off the slaves get nothing,
    docs/simulation.md's ``Q a.b`` row),
    flags from the communication memory, the rest from the program's memory."""
    node = operand.node
    n, b = node.address, node.bit
    kind = node.kind
    if kind is K.I:
        return _data_bits(_slave_inputs(board, n), b)
    if kind is K.IB:
        return _slave_inputs(board, n) | _slave_inputs(board, n + 1) << 4
    if kind is K.Q:
        return _data_bits(board.outputs[n >> 1] >> (n & 1) * 4, b)
    if kind is K.QB:
        return board.outputs[n >> 1]
    if kind is K.F:
        return board.dpram_byte(pc2.FLAGS + n) >> b & 1
    if kind is K.FY:
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


def _data_bits(nibble: int, bit: int) -> int:
    """Data bit ``bit`` of a slave's data, or all four (``I n``, ``Q n``: bit -1)."""
    return nibble & 0xF if bit < 0 else nibble >> bit & 1


def _slave_inputs(board: Pc2Board, address: int) -> int:
    slaves = board.bus.at(address)
    return slaves[0].inputs if slaves else 0
