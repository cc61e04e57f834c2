"""The copies around a program cycle, generated per program: inputs in, outputs out.

Around every cycle the firmware copies the input image (and the previous one) into the
program's cells, the flags the program keeps in internal RAM from the communication
memory, and afterwards the outputs and the changed flags back (docs/runtime.md). Walking
the program map for that costs more than a short program's cycle itself, so the copies
are written out once per program as Python statements with every address a constant.
They read and write XDATA as plain RAM: the runner uses them only while no device is
mapped on the bus.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any

from asictl.runtime import layout
from asictl.runtime.program_map import CellKind, Location, ProgramMap, Space

CopyIn = Callable[[bytearray, bytearray, bytearray, bytes | bytearray | None], tuple[int, ...]]
CopyOut = Callable[[bytearray, bytearray, bytearray, Sequence[int]], None]


def _place(location: Location) -> str:
    return f"{'iram' if location.space is Space.IRAM else 'xram'}[{location.address}]"


def _source(pmap: ProgramMap) -> str:
    def cells(kind: CellKind) -> list[tuple[int, Location]]:
        return sorted((i, loc) for (k, i), loc in pmap.cells.items() if k is kind)

    flags = cells(CellKind.F)
    before = [f"f{n}" for n, _ in flags]
    lines = ["def copy_in(iram, xram, inputs, new):"]
    # the previous cycle's inputs first, then this cycle's
    lines += [f"    {_place(loc)} = inputs[{k}]" for k, loc in cells(CellKind.I2)]
    lines += ["    if new is not None:", "        inputs[:] = new"]
    lines += [f"    {_place(loc)} = inputs[{k}]" for k, loc in cells(CellKind.I)]
    for n, loc in flags:  # flag cells are in internal RAM
        lines += [f"    f{n} = xram[{layout.FLAGS_BASE + n}]", f"    iram[{loc.address}] = f{n}"]
    lines.append(f"    return ({''.join(name + ', ' for name in before)})")
    lines.append("def copy_out(iram, xram, outputs, before):")
    lines += [f"    outputs[{k}] = {_place(loc)}" for k, loc in cells(CellKind.Q)]
    if before:
        lines.append(f"    {', '.join(before)}, = before")
    for n, loc in flags:
        lines += [f"    v = iram[{loc.address}]", f"    if v != f{n}:",
                  f"        xram[{layout.FLAGS_BASE + n}] = v"]
    lines.append("    return None")
    return "\n".join(lines) + "\n"


@functools.lru_cache(maxsize=64)
def _functions(source: str) -> tuple[Any, Any]:
    namespace: dict[str, Any] = {}
    exec(compile(source, "<asictl-cycle-io>", "exec"), namespace)
    return namespace["copy_in"], namespace["copy_out"]


class CycleIo:
    """``copy_in(iram, xram, inputs, new)`` stores ``new`` (if given) as the input image and
    copies images and flags into the cells, returning the flags' values;
    ``copy_out(iram, xram, outputs, flags)`` copies the outputs and the changed flags."""

    def __init__(self, pmap: ProgramMap) -> None:
        copy_in, copy_out = _functions(_source(pmap))
        self.copy_in: CopyIn = copy_in
        self.copy_out: CopyOut = copy_out
