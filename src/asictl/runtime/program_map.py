"""The program map: where a compiled program keeps its process images, timers and data.

The code generator decides it per program (``codegen8051.allocate``); the image carries it
(``image``); the firmware copies inputs, outputs and flags by it around every cycle and
counts the timers it names (``runtime.runner``); the simulator and the monitor read
operands through it. This module is the one definition all of them share.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum

from asictl.runtime import layout


class Space(StrEnum):
    IRAM = "iram"
    XDATA = "xdata"


@dataclass(frozen=True, slots=True, order=True)
class Location:
    space: Space
    address: int

    @property
    def bit_addressable(self) -> bool:
        return self.space is Space.IRAM and 0x20 <= self.address < 0x30

    def bit_address(self, bit: int) -> int:
        return (self.address - 0x20) * 8 + bit


class CellKind(StrEnum):
    """Byte-sized pieces of the process images a program can address bit by bit."""

    I = "I"  # noqa: E741 - the manual's name: input image byte k = slaves 2k, 2k+1
    I2 = "I2"
    Q = "Q"
    F = "F"  # flag byte n
    TS = "TS"  # status bits of timers 8g..8g+7


Cell = tuple[CellKind, int]

def timer_status(number: int) -> tuple[Cell, int]:
    return (CellKind.TS, number >> 3), number & 7


@dataclass
class Variable:
    name: str
    address: int
    size: int


@dataclass
class ProgramMap:
    """Where everything is; the firmware and the simulator read it from the image."""

    cells: dict[Cell, Location] = field(default_factory=dict)
    #: timer number -> XDATA address of its remaining time (2 bytes, low first)
    timers: dict[int, int] = field(default_factory=dict)
    #: counter number -> XDATA address of its count (2 bytes, low first)
    counters: dict[int, int] = field(default_factory=dict)
    #: key(name) -> the variable's XDATA bytes
    variables: dict[str, Variable] = field(default_factory=dict)
    pseg: int = layout.DATA_BASE
    data_end: int = layout.DATA_BASE
    map_counters: bool = False
    #: the timers whose remaining time the program never reads (no ``L T n``, no ASM):
    #: it sees only their status bits, so the ticks before one runs out change nothing
    #: it could tell, and an idle master may count them down in one go. Empty where an
    #: image does not say (format versions 1 and 2): every timer then ticks one by one.
    unread_timers: set[int] = field(default_factory=set)

    def flag(self, n: int) -> Location:
        """Flag byte n: its cell if allocated, else its home in the communication memory."""
        return self.cells.get((CellKind.F, n), Location(Space.XDATA, layout.FLAGS_BASE + n))


@dataclass(frozen=True)
class LoadedProgram:
    """What the firmware needs of a program: its code, where it goes, and its map."""

    code: bytes
    pmap: ProgramMap
    entry_points: dict[str, int]
    code_base: int = layout.CODE_BASE
