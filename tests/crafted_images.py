"""Crafted program images: a valid CRC in front of what the runtime contract forbids.

Each entry of ``CRAFTED`` is an image that passes every check of the format except the
runtime contract's (``runtime.contract``), with the words its refusal must contain. They
are made from ``RICH``, a program with one of everything the firmware reads a program
map for, so that each can break one thing and keep the rest right.
"""

from __future__ import annotations

import copy
import dataclasses
import struct
import zlib
from collections.abc import Callable
from functools import cache
from pathlib import Path

from asictl.build import build, build_file
from asictl.image.eeprom import ProgramImage
from asictl.platform.master import ControlFlag
from asictl.runtime import layout
from asictl.runtime.line_map import LineMap
from asictl.runtime.program_map import CellKind, Location, ProgramMap, Space
from asictl.source import from_string

DEMOS = sorted((Path(__file__).resolve().parents[1] / "demos").glob("*.asi"))
CRC = slice(8, 12)

#: One of everything the firmware reads a map for: timers (two status groups), counters,
#: variables, firmware calls, input, old-input, output and flag cells.
RICH = """\
[SETUP]
  4: iiii, 0
  17: oooo, 0
[DECL]
  Reading BYTE 5
  Level   BYTE 2
  T134    TIMER
  C27     COUNTER
[PROGRAM]
    A   I 4.0
    AN  I2 4.0
    =   Q 17.0
***
    L   KT 500
    A   I 4.0
    S   T 6
    A   T 6
    =   F 10.1
***
    L   KT 200
    A   I 4.0
    S   T 134
    A   T 134
    =   Q 17.1
***
    A   I 4.0
    CU  C 27
    L   Reading 2
    T   Level 0
    JU  FB GetLAS
    BE
[END]
"""


@cache
def rich() -> ProgramImage:
    built = build(from_string("rich.asi", RICH))
    assert built.image is not None, built.render()
    return built.image


@cache
def demo_image(path: Path) -> ProgramImage:
    image = build_file(path).image
    assert image is not None
    return image


def with_crc(data: bytes | bytearray) -> bytes:
    fixed = bytearray(data)
    fixed[CRC] = bytes(4)
    struct.pack_into("<I", fixed, CRC.start, zlib.crc32(fixed))
    return bytes(fixed)


def crafted(change: Callable[[ProgramMap], object], **fields: object) -> bytes:
    """The rich program's image with its map changed and its CRC right."""
    pmap = copy.deepcopy(rich().pmap)
    change(pmap)
    return dataclasses.replace(rich(), pmap=pmap, **fields).to_bytes()


def _cell(pmap: ProgramMap, kind: CellKind) -> tuple[CellKind, int]:
    return next(cell for cell in pmap.cells if cell[0] is kind)


def _set(table: dict, key: object, value: object) -> None:
    table[key] = value


def _variable(pmap: ProgramMap, **change: object) -> None:
    variable = pmap.variables["reading"]
    for name, value in change.items():
        setattr(variable, name, value)


def _relocate_variable(pmap: ProgramMap) -> None:
    pmap.variables["level"].address = pmap.variables["reading"].address + 4


#: name -> (the crafted image, what the refusal says)
CRAFTED: dict[str, tuple[Callable[[], bytes], str]] = {
    "timer without its status cell": (
        lambda: crafted(lambda m: m.cells.pop((CellKind.TS, 0))),
        "timer 6 has no status cell (TS 0)",
    ),
    "cell at internal RAM 300": (
        lambda: crafted(lambda m: _set(m.cells, _cell(m, CellKind.Q), Location(Space.IRAM, 300))),
        "at internal RAM 12Ch; cells lie in 08h-7Fh",
    ),
    "timer at XDATA FFFFh": (
        lambda: crafted(lambda m: _set(m.timers, 6, 0xFFFF)),
        "timer 6 at FFFFh-10000h lies outside the program's data",
    ),
    "cell in register bank 0": (
        lambda: crafted(lambda m: _set(m.cells, _cell(m, CellKind.I), Location(Space.IRAM, 6))),
        "at internal RAM 06h",
    ),
    "cell on the stack": (
        lambda: crafted(lambda m: _set(m.cells, _cell(m, CellKind.I), Location(Space.IRAM, 0x80))),
        "at internal RAM 80h",
    ),
    "two cells in one byte": (
        lambda: crafted(
            lambda m: _set(m.cells, _cell(m, CellKind.Q), m.cells[_cell(m, CellKind.I)])
        ),
        "both at internal RAM",
    ),
    "input cell in the DPRAM": (
        lambda: crafted(
            lambda m: _set(m.cells, _cell(m, CellKind.I), Location(Space.XDATA, 0x210))
        ),
        "at 0210h lies outside the program's data",
    ),
    "flag cell in XDATA": (
        lambda: crafted(lambda m: _set(m.cells, (CellKind.F, 10), Location(Space.XDATA, 0x1000))),
        "cell F 10 in XDATA",
    ),
    "input cell 16": (
        lambda: crafted(lambda m: _set(m.cells, (CellKind.I, 16), Location(Space.IRAM, 0x7F))),
        "cell I 16: there are 16 I cells",
    ),
    "status cell of no timer": (
        lambda: crafted(lambda m: _set(m.cells, (CellKind.TS, 5), Location(Space.IRAM, 0x7F))),
        "cell TS 5: no timer 40..47",
    ),
    "timer 1024": (
        lambda: crafted(lambda m: (
            _set(m.timers, 1024, m.timers.pop(134)),
            _set(m.cells, (CellKind.TS, 128), m.cells.pop((CellKind.TS, 16))),
        )),
        "cell TS 128: there are 128 TS cells (and 1 more problem)",
    ),
    "timer over PSeg": (
        lambda: crafted(lambda m: _set(m.timers, 6, m.pseg + 15)),
        "PSeg at 1000h-100Fh and timer 6 at 100Fh-1010h overlap",
    ),
    "counter past the data": (
        lambda: crafted(lambda m: _set(m.counters, 27, 0x7FFF)),
        "counter 27 at 7FFFh-8000h lies outside",
    ),
    "counters in one word": (
        lambda: crafted(lambda m: _set(m.counters, 28, m.counters[27])),
        "overlap",
    ),
    "mapped counter elsewhere": (
        lambda: crafted(lambda m: (setattr(m, "map_counters", True), _set(m.counters, 3, 0x1000)),
                        flags=ControlFlag.MAP_COUNTERS),
        "with map_counters it is flag bytes 102 and 103",
    ),
    "mapped counter's flag as a cell": (
        lambda: crafted(lambda m: (setattr(m, "map_counters", True),
                                   _set(m.cells, (CellKind.F, 96), Location(Space.IRAM, 0x7F))),
                        flags=ControlFlag.MAP_COUNTERS),
        "flag byte 96 is a counter, never a cell",
    ),
    "variable past the data": (
        lambda: crafted(lambda m: _variable(m, address=m.data_end - 2)),
        "variable Reading at",
    ),
    "variable of no bytes": (
        lambda: crafted(lambda m: _variable(m, size=0)),
        "variable Reading of 0 bytes",
    ),
    "variable named with an escape sequence": (
        lambda: crafted(lambda m: _variable(m, name="\x1b[2J")),
        r"variable '\x1b[2J': not a name",
    ),
    "overlapping variables": (
        lambda: crafted(_relocate_variable),
        "overlap",
    ),
    "data past 8000h": (
        lambda: crafted(lambda m: setattr(m, "data_end", 0x8001)),
        "program data ends at 8001h",
    ),
    "data below 1000h": (
        lambda: crafted(lambda m: setattr(m, "data_end", 0x0FFF)),
        "program data ends at 0FFFh",
    ),
    "PSeg in the DPRAM": (
        lambda: crafted(lambda m: setattr(m, "pseg", 0x200)),
        "PSeg at 0200h-020Fh lies outside",
    ),
    "entry point in the program's code": (
        lambda: crafted(lambda m: None, entry_points={"getlas": layout.CODE_BASE}),
        "GetLAS entry point 4000h lies in the program's own code memory",
    ),
    "entry point at the cycle end": (
        lambda: crafted(lambda m: None, entry_points={"getlas": layout.CYCLE_END}),
        "is the firmware's cycle end",
    ),
    "two blocks at one address": (
        lambda: crafted(lambda m: None, entry_points={"getlas": 0x100, "setpp": 0x100}),
        "both entered at 0100h",
    ),
    "code linked elsewhere": (
        lambda: crafted(lambda m: None, code_base=0x4100, line_map=LineMap()),
        "code linked at 4100h",
    ),
    "no code": (
        lambda: crafted(lambda m: None, code=b""),
        "no code",
    ),
}

def off_table() -> bytes:
    """Entry points possible on some master but not this one's: refused by its load."""
    return crafted(lambda m: None, entry_points={"getlas": 0x0101})
