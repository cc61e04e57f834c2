"""What makes a loaded program runnable: the runtime contract as a check.

The firmware trusts the program map. Every cycle it writes the input, old-input and flag
cells, reads the output cells, counts the timers down and clears their status bits, and
on reset clears the program's data; a monitor reads the timers, counters and variables
by it. An image comes from outside (a file, an upload, any Modbus client writing the
EEPROM), so a map that names memory which does not exist, or that puts two things in one
place, must be refused before anything runs by it: one such image once made every later
command on its board fail.

This module is the one statement of what a valid program is. ``problems`` lists every
way a program breaks the contract; ``ProgramImage.from_bytes`` refuses an image with
any, so every reader (download, upload, a board's reset, the gateway) refuses the same
images with the same words. docs/image-format.md has the rules in prose.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass

from asictl.platform import pc2
from asictl.platform.master import COUNTER_FLAG_BASE, MAPPED_COUNTERS, MAX_TC
from asictl.runtime import layout
from asictl.runtime.firmware import FIRMWARE_BLOCKS
from asictl.runtime.program_map import (
    Cell,
    CellKind,
    LoadedProgram,
    ProgramMap,
    Space,
    timer_status,
)

#: Internal RAM the program's cells may use: between register bank 0 and the stack.
_IRAM_CELLS = frozenset((*layout.DIRECT_POOL, *layout.BIT_POOL))
#: How many cells of each kind exist: the image bytes, the flag bytes, the timer groups.
_CELL_COUNT = {
    CellKind.I: pc2.IMAGE_SIZE,
    CellKind.I2: pc2.IMAGE_SIZE,
    CellKind.Q: pc2.IMAGE_SIZE,
    CellKind.F: pc2.FLAGS_SIZE,
    CellKind.TS: (MAX_TC >> 3) + 1,
}
#: The flag bytes that are counters 0..14 under map_counters: never a cell then.
_COUNTER_FLAGS = range(COUNTER_FLAG_BASE, COUNTER_FLAG_BASE + 2 * MAPPED_COUNTERS)


class ContractError(ValueError):
    """A program the firmware cannot run safely; the message names the first problem."""


@dataclass(frozen=True, order=True)
class _Span:
    """Bytes of the program's XDATA that one thing occupies."""

    start: int
    end: int
    what: str

    def __str__(self) -> str:
        last = self.end - 1
        return f"{self.what} at {self.start:04X}h" + (f"-{last:04X}h" if last > self.start else "")


def problems(program: LoadedProgram, firmware: Mapping[str, int] | None = None) -> list[str]:
    """Every way ``program`` breaks the runtime contract (empty: it may run).

    ``firmware`` is the function-block table of the master that is to run it; without it
    the entry points need only be possible ones (an image may be meant for a master whose
    firmware has its blocks elsewhere).
    """
    return [
        *_code(program),
        *_entry_points(program.entry_points, firmware),
        *_map(program.pmap),
    ]


def check(program: LoadedProgram, firmware: Mapping[str, int] | None = None) -> None:
    """Raise ``ContractError`` naming the first problem (and how many more there are)."""
    found = problems(program, firmware)
    if found:
        more = len(found) - 1
        more_text = f" (and {more} more problem{'s' if more > 1 else ''})" if more else ""
        raise ContractError(found[0] + more_text)


def _code(program: LoadedProgram) -> Iterator[str]:
    if program.code_base != layout.CODE_BASE:
        yield (
            f"code linked at {program.code_base:04X}h; the firmware enters programs at "
            f"{layout.CODE_BASE:04X}h"
        )
    if not program.code:
        yield "no code: every program ends with a return to the firmware"
    elif program.code_base + len(program.code) > layout.CODE_LIMIT:
        yield (
            f"code of {len(program.code)} bytes from {program.code_base:04X}h runs past "
            f"the program's code memory, which ends at {layout.CODE_LIMIT - 1:04X}h"
        )


def _entry_points(
    entry_points: Mapping[str, int], firmware: Mapping[str, int] | None
) -> Iterator[str]:
    used: dict[int, str] = {}
    for name, address in sorted(entry_points.items()):
        block = FIRMWARE_BLOCKS[name].name if name in FIRMWARE_BLOCKS else name
        if name not in FIRMWARE_BLOCKS:
            yield f"entry point of '{name}', which is no firmware block"
        elif firmware is not None and firmware.get(name) != address:
            yield (
                f"{block} linked at {address:04X}h; this master's firmware has it at "
                f"{firmware[name]:04X}h" if name in firmware else f"{block}: not in this firmware"
            )
        elif layout.CODE_BASE <= address < layout.CODE_LIMIT:
            yield (
                f"{block} entry point {address:04X}h lies in the program's own code memory "
                f"({layout.CODE_BASE:04X}h-{layout.CODE_LIMIT - 1:04X}h)"
            )
        elif address == layout.CYCLE_END:
            yield f"{block} entry point {address:04X}h is the firmware's cycle end"
        elif address in used:
            yield f"{block} and {used[address]} both entered at {address:04X}h"
        used.setdefault(address, block)


def _map(pmap: ProgramMap) -> Iterator[str]:
    if not layout.DATA_BASE <= pmap.data_end <= layout.DATA_LIMIT:
        yield (
            f"program data ends at {pmap.data_end:04X}h; it lies in "
            f"{layout.DATA_BASE:04X}h-{layout.DATA_LIMIT - 1:04X}h"
        )
        return  # every placement below is judged against the data area
    spans = [_Span(pmap.pseg, pmap.pseg + 16, "PSeg")]
    yield from _cells(pmap, spans)
    for n, address in sorted(pmap.timers.items()):
        if n > MAX_TC:
            yield f"timer {n}: timers are numbered 0..{MAX_TC}"
        elif timer_status(n)[0] not in pmap.cells:
            yield f"timer {n} has no status cell (TS {n >> 3})"
        spans.append(_Span(address, address + 2, f"timer {n}"))
    for n, address in sorted(pmap.counters.items()):
        if n > MAX_TC:
            yield f"counter {n}: counters are numbered 0..{MAX_TC}"
        elif pmap.map_counters and n < MAPPED_COUNTERS:
            home = layout.FLAGS_BASE + COUNTER_FLAG_BASE + 2 * n
            if address != home:
                yield (
                    f"counter {n} at {address:04X}h; with map_counters it is flag bytes "
                    f"{COUNTER_FLAG_BASE + 2 * n} and {COUNTER_FLAG_BASE + 2 * n + 1} "
                    f"({home:04X}h)"
                )
            continue
        spans.append(_Span(address, address + 2, f"counter {n}"))
    for variable in sorted(pmap.variables.values(), key=lambda v: v.address):
        name = variable.name
        if not name or not name.isprintable() or any(c.isspace() for c in name):
            name = repr(name)  # shown escaped: it may hold terminal control sequences
            yield f"variable {name}: not a name"
        if variable.size < 1:
            yield f"variable {name} of {variable.size} bytes"
        spans.append(_Span(variable.address, variable.address + variable.size, f"variable {name}"))
    yield from _placement(spans, pmap.data_end)


def _cells(pmap: ProgramMap, spans: list[_Span]) -> Iterator[str]:
    """Cells: of a kind and index that exist, in the memory they may use, one per byte."""
    groups = {n >> 3 for n in pmap.timers}
    in_iram: dict[int, Cell] = {}
    for (kind, index), location in sorted(pmap.cells.items()):
        name = f"cell {kind} {index}"
        if index >= _CELL_COUNT[kind]:
            yield f"{name}: there are {_CELL_COUNT[kind]} {kind} cells"
            continue
        if kind is CellKind.TS and index not in groups:
            yield f"{name}: no timer {8 * index}..{8 * index + 7} to give status to"
        if kind is CellKind.F and pmap.map_counters and index in _COUNTER_FLAGS:
            yield f"{name}: with map_counters flag byte {index} is a counter, never a cell"
        if location.space is Space.IRAM:
            if location.address not in _IRAM_CELLS:
                yield (
                    f"{name} at internal RAM {location.address:02X}h; cells lie in "
                    f"{min(_IRAM_CELLS):02X}h-{max(_IRAM_CELLS):02X}h, between the "
                    "register bank and the stack"
                )
            elif location.address in in_iram:
                other = in_iram[location.address]
                yield (
                    f"{name} and cell {other[0]} {other[1]} both at internal RAM "
                    f"{location.address:02X}h"
                )
            in_iram.setdefault(location.address, (kind, index))
        elif kind is CellKind.F:
            yield f"{name} in XDATA; flag cells are in internal RAM (else the flag stays home)"
        else:
            spans.append(_Span(location.address, location.address + 1, name))


def _placement(spans: list[_Span], data_end: int) -> Iterator[str]:
    """Everything in XDATA lies in the program's data area, nothing overlapping."""
    inside = []
    for span in spans:
        if span.start >= layout.DATA_BASE and span.end <= data_end:
            inside.append(span)
        else:
            yield (
                f"{span} lies outside the program's data "
                f"{layout.DATA_BASE:04X}h-{data_end - 1:04X}h"
            )
    inside.sort()
    reach: _Span | None = None  # of the spans so far, the one that ends last
    for span in inside:
        if reach is not None and span.start < reach.end:
            yield f"{reach} and {span} overlap"
        if reach is None or span.end > reach.end:
            reach = span
