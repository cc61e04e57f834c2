"""The firmware's side of the runtime contract: running a compiled program's cycles.

docs/runtime.md is the contract; this is its one implementation, used by the emulated
master and by the tests that hold the compiled code against the reference interpreter.
Per cycle it copies the inputs (and the previous inputs) into the program's cells and
the flags it keeps in internal RAM, calls the program with the stack set up so that its
final RET lands on the cycle-end trap, and copies outputs and changed flags back.
Timers count down in ``tick``, between cycles, as the master's 10 ms clock does.

Speed: the copies are generated per program (``cycle_io``) as straight Python code with
every address a constant, and the emulator runs the program's hot code as regions. Both
are the fast path; ``fast=False`` gives the general one (the copies walk the program
map, the emulator translates blocks only), which tests hold the fast one against.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from asictl.mcs51.bus import Bus
from asictl.mcs51.emulator import Emulator, StopReason, exit_trap
from asictl.mcs51.loops import looping_jumps
from asictl.platform import pc2
from asictl.runtime import layout
from asictl.runtime.cycle_io import CycleIo
from asictl.runtime.firmware import FIRMWARE_BLOCKS, FirmwareServices
from asictl.runtime.program_map import (
    CellKind,
    LoadedProgram,
    Location,
    Space,
    timer_status,
)

#: called after each instruction with the emulator and the instruction's address
Trace = Callable[[Emulator, int], None]

_RET = 0x22
_TRAP = StopReason.TRAP  # the end of every cycle: a module constant


class CycleTimeout(Exception):
    """The program ran past the cycle budget (an endless loop); the master stops it.
    The reference interpreter (il/oracle.py) raises it too, for its own budget."""


class ProgramRunner:
    """Runs one loaded program on an 8051 emulator whose XDATA holds the DPRAM."""

    def __init__(
        self,
        program: LoadedProgram,
        *,
        firmware: FirmwareServices | None = None,
        xdata: Bus | None = None,
        budget: int = layout.CYCLE_BUDGET,
        fast: bool = True,
    ) -> None:
        self.program = program
        self.pmap = program.pmap
        self.firmware = firmware
        self.budget = budget
        self.cpu = Emulator(xdata=xdata, regions=fast)
        self._io = CycleIo(program.pmap) if fast else None
        self.cpu.code.load(program.code_base, program.code)
        self.cpu.code[layout.CYCLE_END] = _RET
        self.cpu.add_trap(layout.CYCLE_END, exit_trap)
        for name, address in program.entry_points.items():
            self.cpu.code[address] = _RET
            self.cpu.add_trap(address, self._firmware_trap(FIRMWARE_BLOCKS[name].name))
        self.inputs = bytearray(16)
        self.outputs = bytearray(16)
        self._cells = {kind: self._cells_of(kind) for kind in CellKind}
        #: whether the program reads the previous-cycle inputs (I2): then the input image
        #: it keeps between cycles is part of its state
        self.reads_previous_inputs = bool(self._cells[CellKind.I2])
        self._timers = [
            (self.pmap.timers[n], self.pmap.cells[timer_status(n)[0]], timer_status(n)[1])
            for n in sorted(self.pmap.timers)
        ]
        #: machine cycles the last program cycle took
        self.last_cycles = 0
        #: what watches the cycles (coverage): called before each cycle with its inputs,
        #: it answers the function the emulator then calls after every instruction of the
        #: cycle (which runs in the interpreter), or None to run it at full speed
        self.watch: Callable[[bytes | bytearray | None], Trace | None] | None = None

    def _cells_of(self, kind: CellKind) -> list[tuple[int, Location]]:
        return sorted((i, loc) for (k, i), loc in self.pmap.cells.items() if k is kind)

    # ------------------------------------------------------------------ memory

    def read(self, location: Location) -> int:
        if location.space is Space.IRAM:
            return self.cpu.iram[location.address]
        return self.cpu.xdata.read(location.address)

    def write(self, location: Location, value: int) -> None:
        if location.space is Space.IRAM:
            self.cpu.iram[location.address] = value
        else:
            self.cpu.xdata.write(location.address, value)

    def flag(self, n: int) -> int:
        """Flag byte n as the program sees it (its cell between cycles equals the DPRAM)."""
        return self.read(self.pmap.flag(n))

    def reset(self) -> None:
        """reset_bit: clear the program's memory, flags, images and the IL registers."""
        self.cpu.iram[:] = bytes(256)
        for address in range(layout.DATA_BASE, self.pmap.data_end):
            self.cpu.xdata.write(address, 0)
        for n in range(128):
            self.cpu.xdata.write(layout.FLAGS_BASE + n, 0)
        self.inputs[:] = bytes(16)
        self.outputs[:] = bytes(16)

    # ------------------------------------------------------------------ the cycle

    def cycle(self, inputs: bytes | bytearray | None = None) -> None:
        """One program cycle; raises ``CycleTimeout`` when the budget runs out."""
        cpu = self.cpu
        watch = self.watch
        trace = watch(inputs) if watch is not None else None
        xdata = cpu.xdata
        io = self._io if xdata.plain else None  # the copies assume plain XDATA RAM
        flags: Sequence[int]
        if io is not None:
            flags = io.copy_in(cpu.iram, xdata.ram, self.inputs, inputs)
        else:
            flags = self._copy_in(inputs)
        start = cpu.cycles
        # positional: asked every cycle
        reason = cpu.call(self.program.code_base, layout.CYCLE_END, layout.STACK_START,
                          self.budget, trace)
        self.last_cycles = cpu.cycles - start
        if reason is not _TRAP:
            jumps = looping_jumps(cpu)
            address = jumps[-1] if jumps else cpu.pc
            cpu.xdata.write(pc2.STOP_ADDRESS, address & 0xFF)  # for the host: which loop
            cpu.xdata.write(pc2.STOP_ADDRESS + 1, address >> 8)
            raise CycleTimeout(
                f"program cycle longer than {self.budget} machine cycles (loop at "
                f"{address:04X}h)"
            )
        if io is not None:
            io.copy_out(cpu.iram, xdata.ram, self.outputs, flags)
        else:
            self._copy_out(flags)

    def _copy_in(self, inputs: bytes | bytearray | None) -> list[int]:
        """Inputs, previous inputs and flags into the program's cells (the general path);
        returns the flags' values, so that only the ones the program changed go back."""
        cpu = self.cpu
        previous = bytes(self.inputs)
        if inputs is not None:
            self.inputs[:] = inputs
        for k, location in self._cells[CellKind.I]:
            self.write(location, self.inputs[k])
        for k, location in self._cells[CellKind.I2]:
            self.write(location, previous[k])
        flags = [cpu.xdata.read(layout.FLAGS_BASE + n) for n, _ in self._cells[CellKind.F]]
        for (_, location), value in zip(self._cells[CellKind.F], flags, strict=True):
            cpu.iram[location.address] = value
        return flags

    def _copy_out(self, flags: Sequence[int]) -> None:
        """Outputs and the flags the program changed back (the general path)."""
        cpu = self.cpu
        for k, location in self._cells[CellKind.Q]:
            self.outputs[k] = self.read(location)
        for (n, location), before in zip(self._cells[CellKind.F], flags, strict=True):
            value = cpu.iram[location.address]
            if value != before:
                cpu.xdata.write(layout.FLAGS_BASE + n, value)

    def enter(self) -> None:
        """Call the program as the firmware does: bank 0, the stack set up so that its
        final RET lands on the cycle-end trap, the PC at its code base."""
        self.cpu.prepare_call(self.program.code_base, layout.CYCLE_END, layout.STACK_START)

    def tick(self, ticks: int = 1) -> bool:
        """``ticks`` x 10 ms of master time: running timers count down, status follows.
        Returns whether a timer ran (a tick of stopped timers changes nothing)."""
        xdata = self.cpu.xdata
        if self._io is not None and xdata.plain:  # plain RAM, the common case: generated
            return self._io.tick(self.cpu.iram, xdata.ram, ticks)
        read, write = xdata.read, xdata.write
        ran = False
        for address, location, bit in self._timers:
            remaining = read(address) | read(address + 1) << 8
            if remaining:
                ran = True
                remaining = remaining - ticks if remaining > ticks else 0  # no max() call
                write(address, remaining & 0xFF)
                write(address + 1, remaining >> 8)
                if not remaining:
                    self.write(location, self.read(location) & ~(1 << bit) & 0xFF)
        return ran

    def _firmware_trap(self, name: str) -> Callable[[Emulator], None]:
        def trap(cpu: Emulator) -> None:
            base = cpu.dptr  # PSeg's 16 bytes from here, wrapping at 64 KB as DPTR does
            pseg = bytearray(cpu.xdata.read(base + i & 0xFFFF) for i in range(16))
            if self.firmware is not None:
                self.firmware.call(name, pseg)
            for i, value in enumerate(pseg):
                cpu.xdata.write(base + i & 0xFFFF, value)
            cpu.ret()

        return trap
