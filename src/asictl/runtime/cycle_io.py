"""The copies around a program cycle, generated per program: inputs in, outputs out;
and the 10 ms tick of its timers.

Around every cycle the firmware copies the input image (and the previous one) into the
program's cells, the flags the program keeps in internal RAM from the communication
memory, and afterwards the outputs and the changed flags back (docs/runtime.md). Walking
the program map for that costs more than a short program's cycle itself, so the copies
are written out once per program as Python statements with every address a constant,
and so is the tick, which counts the running timers down between cycles. They read and
write XDATA as plain RAM: the runner uses them only while no device is mapped on the bus.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any

from asictl.runtime import layout
from asictl.runtime.program_map import CellKind, Location, ProgramMap, Space, timer_status

CopyIn = Callable[[bytearray, bytearray, bytearray, bytes | bytearray | None], tuple[int, ...]]
CopyOut = Callable[[bytearray, bytearray, bytearray, Sequence[int]], None]
Tick = Callable[[bytearray, bytearray, int], bool]


def _place(location: Location) -> str:
    return f"{'iram' if location.space is Space.IRAM else 'xram'}[{location.address}]"


def _gather(name: str, source: str, addresses: list[int]) -> tuple[list[str], str]:
    """A tuple of the bytes at ``addresses`` of ``source``, read in one C call
    (``operator.itemgetter``): the getter's definition and the expression."""
    if len(addresses) == 1:  # an itemgetter of one index answers the byte, not a tuple
        return [], f"({source}[{addresses[0]}],)"
    return [f"{name} = itemgetter({', '.join(map(str, addresses))})"], f"{name}({source})"


def _source(pmap: ProgramMap) -> str:
    def cells(kind: CellKind) -> list[tuple[int, Location]]:
        return sorted((i, loc) for (k, i), loc in pmap.cells.items() if k is kind)

    flags = cells(CellKind.F)  # flag cells are in internal RAM
    before = [f"f{n}" for n, _ in flags]
    after = [f"v{n}" for n, _ in flags]
    getters = ["from operator import itemgetter"]
    lines = ["def copy_in(iram, xram, inputs, new):"]
    # the previous cycle's inputs first, then this cycle's
    lines += [f"    {_place(loc)} = inputs[{k}]" for k, loc in cells(CellKind.I2)]
    lines += ["    if new is not None:", "        inputs[:] = new"]
    lines += [f"    {_place(loc)} = inputs[{k}]" for k, loc in cells(CellKind.I)]
    if flags:
        getter, values = _gather("_communication_flags", "xram",
                                 [layout.FLAGS_BASE + n for n, _ in flags])
        getters += getter
        getter, held = _gather("_flag_cells", "iram", [loc.address for _, loc in flags])
        getters += getter
        # The cells hold what the last cycle left, which is what the flags are unless
        # someone wrote them since: one comparison in place of a store per flag.
        lines += [f"    flags = {values}", f"    if {held} != flags:",
                  f"        {', '.join(_place(loc) for _, loc in flags)}, = flags",
                  "    return flags"]
    else:
        lines.append("    return ()")
    lines.append("def copy_out(iram, xram, outputs, before):")
    outputs = cells(CellKind.Q)
    if outputs and all(loc.space is Space.IRAM for _, loc in outputs):
        getter, values = _gather("_output_cells", "iram", [loc.address for _, loc in outputs])
        getters += getter
        lines.append(f"    {', '.join(f'outputs[{k}]' for k, _ in outputs)}, = {values}")
    else:
        lines += [f"    outputs[{k}] = {_place(loc)}" for k, loc in outputs]
    if flags:  # only the flags the program changed go back
        values = _gather("_flag_cells", "iram", [loc.address for _, loc in flags])[1]
        lines += [f"    after = {values}", "    if after != before:",
                  f"        {', '.join(before)}, = before", f"        {', '.join(after)}, = after"]
        for (n, _), old, new in zip(flags, before, after, strict=True):
            lines += [f"        if {new} != {old}:",
                      f"            xram[{layout.FLAGS_BASE + n}] = {new}"]
    lines.append("    return None")
    lines += _tick(pmap)
    return "\n".join(getters + lines) + "\n"


def _tick(pmap: ProgramMap) -> list[str]:
    """``tick(iram, xram, ticks)``: each running timer's word counts down by ``ticks``, not
    below 0, and its status bit clears when it reaches 0; True when a timer ran."""
    lines = ["def tick(iram, xram, ticks):", "    ran = False"]
    for n in sorted(pmap.timers):
        word = pmap.timers[n]
        cell, bit = timer_status(n)
        status = _place(pmap.cells[cell])
        lines += [f"    remaining = xram[{word}] | xram[{word + 1}] << 8",
                  "    if remaining:",
                  "        ran = True",
                  "        if remaining > ticks:",
                  "            remaining -= ticks",
                  f"            xram[{word}] = remaining & 255",
                  f"            xram[{word + 1}] = remaining >> 8",
                  "        else:",
                  f"            xram[{word}] = xram[{word + 1}] = 0",
                  f"            {status} &= {~(1 << bit) & 0xFF}"]
    lines.append("    return ran")
    return lines


@functools.lru_cache(maxsize=64)
def _functions(source: str) -> tuple[Any, Any, Any]:
    namespace: dict[str, Any] = {}
    exec(compile(source, "<asictl-cycle-io>", "exec"), namespace)
    return namespace["copy_in"], namespace["copy_out"], namespace["tick"]


class CycleIo:
    """``copy_in(iram, xram, inputs, new)`` stores ``new`` (if given) as the input image and
    copies images and flags into the cells, returning the flags' values;
    ``copy_out(iram, xram, outputs, flags)`` copies the outputs and the changed flags;
    ``tick(iram, xram, ticks)`` counts the running timers down (True if one ran)."""

    def __init__(self, pmap: ProgramMap) -> None:
        copy_in, copy_out, tick = _functions(_source(pmap))
        self.copy_in: CopyIn = copy_in
        self.copy_out: CopyOut = copy_out
        self.tick: Tick = tick
