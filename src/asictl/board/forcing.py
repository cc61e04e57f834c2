"""Forcing: values the emulated master holds whatever the control program does.

A PLC runtime's force list (TIA's, CODESYS's) in the control program's frame around each
program cycle, at three points (docs/commissioning.md, "Forcing"):

- a forced *input* is what the program reads: the input image handed to the program
  (and so the previous-cycle image I2 of the next cycle) carries the forced bits, while
  the IDI in the DPRAM still shows what the slave delivers;
- a forced *output* is what the slave receives: the forced bits replace the program's
  (or, while it is stopped, the host's) outputs on their way to the cable, and the ODI
  the program's cycle writes shows them;
- a forced *flag* is written again after every program cycle and every AS-i cycle, so
  the program reads it at the start of its next cycle whatever it wrote, and so does the
  host.

The real PC2 firmware has none of this: only the emulated board forces. The forces are
part of the board's saved state (``Nonvolatile.forced``), so they hold until released,
across commands, a reset and a restart of ``asictl serve``.

Each area maps a slave (inputs, outputs: its four data bits) or a flag byte to a mask of
forced bits and their values; this module knows nothing of operand names (the host
turns ``F 10.0=1`` into flag byte 10, mask 01h, bits 01h).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from asictl.platform.master import SLAVES
from asictl.platform.pc2 import FLAGS_SIZE


class Area(StrEnum):
    INPUTS = "inputs"
    OUTPUTS = "outputs"
    FLAGS = "flags"


#: Per area: the bits one index holds (a slave's four data bits, a flag byte).
BITS = {Area.INPUTS: 0xF, Area.OUTPUTS: 0xF, Area.FLAGS: 0xFF}
#: Per area: the largest index.
_LARGEST = {Area.INPUTS: SLAVES - 1, Area.OUTPUTS: SLAVES - 1, Area.FLAGS: FLAGS_SIZE - 1}


class ForceError(ValueError):
    """A force the board cannot hold (an index or mask out of range, a malformed state)."""


@dataclass
class Forces:
    """The force list: per area, index -> (mask, bits), bits only under the mask."""

    areas: dict[Area, dict[int, tuple[int, int]]] = field(
        default_factory=lambda: {area: {} for area in Area}
    )

    def __bool__(self) -> bool:
        return any(self.areas.values())

    def force(self, area: Area, index: int, mask: int, bits: int) -> None:
        """The bits under ``mask`` of ``index`` are held at ``bits`` (added to the bits
        already forced there)."""
        _check(area, index, mask)
        table = self.areas[area]
        old_mask, old_bits = table.get(index, (0, 0))
        table[index] = (old_mask | mask, old_bits & ~mask | bits & mask)

    def release(self, area: Area, index: int, mask: int) -> bool:
        """Release the bits under ``mask``; False if none of them was forced."""
        _check(area, index, mask)
        table = self.areas[area]
        old_mask, old_bits = table.get(index, (0, 0))
        if not old_mask & mask:
            return False
        left = old_mask & ~mask
        if left:
            table[index] = (left, old_bits & left)
        else:
            del table[index]
        return True

    def clear(self) -> int:
        """Release everything; returns how many indices were forced."""
        count = sum(len(table) for table in self.areas.values())
        for table in self.areas.values():
            table.clear()
        return count

    def entries(self) -> list[tuple[Area, int, int, int]]:
        """(area, index, mask, bits) of every forced index, inputs, outputs, flags in
        order, by index."""
        return [
            (area, index, mask, bits)
            for area in Area
            for index, (mask, bits) in sorted(self.areas[area].items())
        ]

    # ------------------------------------------------------------------ the three points

    def inputs(self, image: bytes | bytearray) -> bytes | bytearray:
        """The input image the program reads: ``image`` (two slaves a byte, as the IDI)
        with the forced bits in place."""
        return _apply(image, self.areas[Area.INPUTS])

    def outputs(self, image: bytes | bytearray) -> bytes | bytearray:
        """The output image the slaves receive (not inverted)."""
        return _apply(image, self.areas[Area.OUTPUTS])

    def rewrite_flags(self, ram: bytearray, base: int) -> bool:
        """Write the forced flag bits into the flag bytes at ``base``; True if one
        changed."""
        changed = False
        for index, (mask, bits) in self.areas[Area.FLAGS].items():
            old = ram[base + index]
            new = old & ~mask | bits
            if new != old:
                ram[base + index] = new
                changed = True
        return changed

    # ------------------------------------------------------------------ saved state

    def to_json(self) -> dict[str, list[list[int]]]:
        return {
            area.value: [[index, mask, bits] for index, (mask, bits) in sorted(table.items())]
            for area, table in self.areas.items()
        }

    @classmethod
    def from_json(cls, data: Any) -> Forces:
        """What ``to_json`` wrote; ``ForceError`` naming what is wrong."""
        forces = cls()
        if not isinstance(data, dict) or set(data) - {a.value for a in Area}:
            raise ForceError("'forced' must be an object with inputs, outputs and flags")
        for name, rows in data.items():
            area = Area(name)
            if not isinstance(rows, list):
                raise ForceError(f"'forced.{name}' must be a list of [index, mask, bits]")
            for row in rows:
                if not (isinstance(row, list) and len(row) == 3 and all(
                        isinstance(v, int) and not isinstance(v, bool) for v in row)):
                    raise ForceError(f"'forced.{name}' must be a list of [index, mask, bits]")
                index, mask, bits = row
                forces.force(area, index, mask, bits)
        return forces


def _check(area: Area, index: int, mask: int) -> None:
    largest, bits = _LARGEST[area], BITS[area]
    first = 0 if area is Area.FLAGS else 1
    if not first <= index <= largest:
        what = "flag byte" if area is Area.FLAGS else "slave"
        raise ForceError(f"forced {area.value}: {what} {index} is not {first}..{largest}")
    if not 0 < mask <= bits:
        raise ForceError(f"forced {area.value}: mask {mask:X}h is not 1..{bits:X}h")


def _apply(image: bytes | bytearray, table: dict[int, tuple[int, int]]) -> bytes | bytearray:
    if not table:
        return image
    forced = bytearray(image)
    for slave, (mask, bits) in table.items():
        shift = 4 * (slave & 1)
        forced[slave >> 1] = forced[slave >> 1] & ~(mask << shift) | bits << shift
    return forced
