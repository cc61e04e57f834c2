"""Watching a running program line by line, without changing its code.

The emulator calls a trap whenever the PC reaches its address (``Emulator.add_trap``);
traps at the start address of every IL line's code (the line map) therefore see each
line begin, a trap at the program's entry sees each cycle begin, and the runner's own
cycle-end trap, wrapped, sees each cycle end. Installed traps make the emulator stop its
translated blocks at those addresses, so a program runs at full speed whenever no hooks
are installed.

The master skips a cycle that would repeat the one before exactly (a cycle that called
no firmware block and left the machine as it found it). A watched cycle must really
run, so the hooks count as a firmware call, which is exactly what keeps the master from
skipping the next cycles.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from asictl.mcs51.emulator import Emulator
from asictl.runtime import layout
from asictl.runtime.line_map import LineMap, SourceLine
from asictl.runtime.runner import ProgramRunner

LineHook = Callable[[SourceLine, int], None]


class LineHooks:
    """Calls ``on_line(line, address)`` at each line start, ``on_cycle_start()`` as each
    program cycle begins and ``on_cycle_end()`` when it returns to the firmware."""

    def __init__(
        self,
        runner: ProgramRunner,
        line_map: LineMap,
        *,
        on_line: LineHook | None = None,
        on_cycle_start: Callable[[], None] | None = None,
        on_cycle_end: Callable[[], None] | None = None,
    ) -> None:
        self.runner = runner
        self.line_map = line_map
        self.on_line = on_line
        self.on_cycle_start = on_cycle_start
        self.on_cycle_end = on_cycle_end
        self._installed: list[int] = []
        self._cycle_end: Any = None

    def install(self) -> None:
        if self._installed:
            return
        cpu = self.runner.cpu
        starts = self.line_map.line_starts() if self.on_line is not None else {}
        entry = self.runner.program.code_base
        for address in sorted({*starts, entry}):
            cpu.add_trap(address, self._trap(address, starts.get(address), address == entry))
            self._installed.append(address)
        self._cycle_end = cpu.traps.get(layout.CYCLE_END)
        if self._cycle_end is not None:
            original = self._cycle_end

            def cycle_end(emulator: Emulator) -> bool | None:
                if self.on_cycle_end is not None:
                    self.on_cycle_end()
                result: bool | None = original(emulator)
                return result

            cpu.add_trap(layout.CYCLE_END, cycle_end)

    def remove(self) -> None:
        cpu = self.runner.cpu
        for address in self._installed:
            cpu.remove_trap(address)
        self._installed = []
        if self._cycle_end is not None:
            cpu.add_trap(layout.CYCLE_END, self._cycle_end)
            self._cycle_end = None

    def _trap(
        self, address: int, line: SourceLine | None, entry: bool
    ) -> Callable[[Emulator], None]:
        def trap(emulator: Emulator) -> None:
            if entry:
                self._keep_awake()
                if self.on_cycle_start is not None:
                    self.on_cycle_start()
            if line is not None and self.on_line is not None:
                self.on_line(line, address)

        return trap

    def _keep_awake(self) -> None:
        firmware = self.runner.firmware
        if firmware is not None and hasattr(firmware, "calls"):
            firmware.calls += 1
