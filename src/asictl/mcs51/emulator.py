"""An MCS-51 (8051) emulator fast enough to run AS-i master firmware in pure Python.

Every instruction's behaviour is written once, as Python source templates
(:mod:`asictl.mcs51.templates`). The templates are turned into code two ways:

* **Handlers** (the interpreter): one function per opcode, fetching its operand bytes
  and the register bank at run time. Single-stepping and tracing use these.
* **Blocks** (the translator): straight-line code from a start address up to the next
  jump, call, return or register-bank switch, compiled into one Python function with
  every operand folded to a constant, register-bank addresses resolved, and ACC, PSW
  and DPTR held in local variables. Blocks are cached per (address, register bank).

Both paths come from the same templates, so they cannot disagree about what an
instruction does; tests still compare them on random programs. Lengths and cycle
counts come from the shared instruction table (:mod:`asictl.mcs51.isa`), which the
assembler and disassembler use too.

Three invariants the generated code relies on:

* During a run, bit 0 of ``sfr[PSW]`` (the parity flag) is kept 0 and parity is
  computed from ACC when PSW is read; :meth:`Emulator.run` stores the true parity when
  it returns, and the ``psw`` property always computes it. Generated code keeps the
  carry apart from the rest of PSW, in a local of its own (0 or 1): bit logic, which
  is most of a PLC program, then works on a plain local.
* A block never contains a breakpoint, trap or ``until`` address except as its first
  instruction, so stopping is only ever decided between blocks.
* A block never changes the register bank except in its last instruction, so register
  addresses inside it are constants.
"""

from __future__ import annotations

import enum
import functools
from collections.abc import Callable
from types import CodeType
from typing import Any

from asictl.errors import ExitCode, UserError
from asictl.mcs51.bus import Bus, CodeMemory
from asictl.mcs51.isa import OPCODES, UNDEFINED_OPCODE
from asictl.mcs51.regions import BIT_TABLES, build_region
from asictl.mcs51.templates import ACC, DPH, DPL, PARITY, PORTS, PSW, SP, B, Writer

#: Longest block, in instructions. Longer blocks save dispatches but a run whose
#: remaining budget is smaller than the block finishes in the interpreter.
MAX_BLOCK = 48

_CYCLES = tuple(info.cycles if info else 0 for info in OPCODES)


class EmulatorError(UserError):
    """The emulated program did something the 8051 does not define."""

    exit_code = ExitCode.FAILED


class UndefinedOpcode(EmulatorError):
    """The program fetched A5h, the one opcode the MCS-51 leaves undefined."""

    def __init__(self, pc: int) -> None:
        self.pc = pc
        self.opcode = UNDEFINED_OPCODE
        super().__init__(f"undefined opcode {UNDEFINED_OPCODE:02X}h at {pc:04X}h")


class StopReason(enum.Enum):
    """Why :meth:`Emulator.run` returned."""

    INSTRUCTIONS = "instruction budget exhausted"
    CYCLES = "cycle budget exhausted"
    BREAKPOINT = "breakpoint"
    UNTIL = "until address reached"
    TRAP = "stopped by trap"


# What ``run`` answers, as module constants: an enum member's lookup costs more than
# a call, and a program cycle's run answers once per cycle.
_INSTRUCTIONS, _CYCLES_SPENT, _BREAKPOINT, _UNTIL, _TRAP = (
    StopReason.INSTRUCTIONS, StopReason.CYCLES, StopReason.BREAKPOINT, StopReason.UNTIL,
    StopReason.TRAP,
)

#: A firmware service written in Python, called when the PC reaches its address, before
#: the instruction there executes. It may change any state; if it moves the PC (for
#: example with :meth:`Emulator.ret`) execution continues there, otherwise the
#: instruction at the trap address runs. Returning a true value stops the run.
Trap = Callable[["Emulator"], object]


def exit_trap(emulator: Emulator) -> bool:
    """The trap of an address where a run ends: the return address a caller pushed for
    code it calls (the firmware's call of a program cycle). A call whose code is one
    translated region that ends here is done in one step (``Emulator.call``)."""
    return True


_FACTORY_HEADER = "def factory(iram, sfr, code, xram, xrd, xwr, pins, emu, iterations):\n"


@functools.lru_cache(maxsize=8192)
def _compile(source: str) -> CodeType:
    """Compile generated source once per process; emulators share the code objects."""
    return compile(source, "<mcs51-translation>", "exec")


def _instantiate(source: str, emu: Emulator) -> Any:
    """What the generated ``factory`` returns: the handlers' tuple, or a block function."""
    namespace: dict[str, Any] = {"PAR": PARITY, **BIT_TABLES}
    exec(_compile(source), namespace)
    bus = emu.xdata
    return namespace["factory"](
        emu.iram,
        emu.sfr,
        emu.code,
        bus.ram,
        bus.readers,
        bus.writers,
        emu.pins,
        emu,
        emu._iterations,
    )


def _handler_source() -> str:
    """One interpreter handler per defined opcode, returned as a 256-entry tuple."""
    parts = [_FACTORY_HEADER]
    names = []
    for info in OPCODES:
        if info is None:
            names.append("None")
            continue
        writer = Writer(static=False)
        writer.instruction(info, None, None)
        name = f"op_{info.opcode:02x}"
        parts.append(writer.finish(name, "np" if writer.falls_through else None) + "\n")
        names.append(name)
    parts.append(f"    return ({', '.join(names)},)\n")
    return "".join(parts)


_HANDLERS = _handler_source()


def _undefined_block(pc: int) -> Callable[[], int]:
    def undefined() -> int:
        raise UndefinedOpcode(pc)

    return undefined


#: Kinds of translated code: a block, a block that loops to its own start (called with the
#: iterations the budget allows, see ``Writer.finish``), a region (regions.py: called
#: when one pass's most instructions and cycles fit the budget, with the budget left for
#: the passes round its loop; it leaves the ones it ran in ``iterations``), and a block
#: standing in for a region until its address is hot.
_BLOCK, _LOOP, _REGION, _WARM = 0, 1, 2, 3
#: How often a block runs before a region replaces it. Translating a region costs some
#: 30 us per instruction; a program cycle repeats thousands of times, code run once
#: (a test's random program, a start-up routine) is not worth it.
HOT = 8
#: A translation cache entry: the function (None to hand control back to the run loop: a
#: stop address or trap), its instructions and machine cycles (a region's most), its kind.
Entry = tuple[Callable[..., int] | None, int, int, int]
#: An entry with code to run.
Translated = tuple[Callable[..., int], int, int, int]
_STOP_ENTRY: Entry = (None, 0, 0, _BLOCK)
_UNLIMITED = 1 << 62


class Emulator:
    """One 8051 core: registers, internal RAM, SFRs, code memory and an XDATA bus.

    State is plain data meant to be read and written directly: ``iram`` (256 bytes),
    ``sfr`` (256 bytes indexed by SFR address; 80h-FFh are used), ``code``, ``xdata``,
    ``pins`` (the external input on P0-P3, default FFh: unconnected pins read high),
    ``pc`` and the counters ``instructions`` and ``cycles`` (machine cycles).

    ``translate=False`` runs everything in the interpreter, which is slower but updates
    state one instruction at a time (for device callbacks that need exact counters).
    """

    #: runs of a block before a region replaces it (HOT; tests use 1 to test regions)
    hot = HOT

    def __init__(
        self, *, xdata: Bus | None = None, translate: bool = True, regions: bool = True
    ) -> None:
        self.code = CodeMemory()
        self.code.on_write = self._invalidate
        self.xdata = xdata if xdata is not None else Bus()
        self.iram = bytearray(256)
        self.sfr = bytearray(256)
        self.pins = bytearray(b"\xff" * 4)
        self.translate = translate
        self._regions = regions
        self.pc = 0
        self.instructions = 0
        self.cycles = 0
        self._breakpoints: set[int] = set()
        self._traps: dict[int, Trap] = {}
        self._blocks: dict[int, Entry] = {}
        self._plain: dict[int, Translated] = {}  # blocks where a region does not fit the budget
        self._heat: dict[int, int] = {}  # how often each warm block ran
        # how often the last self-looping block went round; what the last region ran
        self._iterations = [0, 0]
        self._stops: frozenset[int] = frozenset()
        # the ``until`` the stop addresses include; False when they may have changed
        self._stops_until: int | None = None
        self._stops_current = False
        self._handlers: tuple[Callable[[int], int] | None, ...] = _instantiate(_HANDLERS, self)
        self.reset()

    # -- state ----------------------------------------------------------------------

    def reset(self) -> None:
        """Hardware reset: SFRs to their reset values, PC and counters to 0.

        Internal RAM and XDATA keep their contents, as on the chip.
        """
        self.sfr[:] = bytes(256)
        for port in PORTS:
            self.sfr[port] = 0xFF
        self.sfr[SP] = 0x07
        self.pc = 0
        self.instructions = 0
        self.cycles = 0

    @property
    def a(self) -> int:
        return self.sfr[ACC]

    @a.setter
    def a(self, value: int) -> None:
        self.sfr[ACC] = value
        self.sfr[PSW] = self.sfr[PSW] & 0xFE | PARITY[value]

    @property
    def b(self) -> int:
        return self.sfr[B]

    @b.setter
    def b(self, value: int) -> None:
        self.sfr[B] = value

    @property
    def psw(self) -> int:
        """PSW with the parity flag computed from ACC, as the hardware keeps it."""
        return self.sfr[PSW] & 0xFE | PARITY[self.sfr[ACC]]

    @psw.setter
    def psw(self, value: int) -> None:
        self.sfr[PSW] = value & 0xFE | PARITY[self.sfr[ACC]]

    @property
    def sp(self) -> int:
        return self.sfr[SP]

    @sp.setter
    def sp(self, value: int) -> None:
        self.sfr[SP] = value

    @property
    def dptr(self) -> int:
        return self.sfr[DPH] << 8 | self.sfr[DPL]

    @dptr.setter
    def dptr(self, value: int) -> None:
        self.sfr[DPH], self.sfr[DPL] = value >> 8 & 0xFF, value & 0xFF

    @property
    def bank(self) -> int:
        """The register bank PSW.RS1/RS0 selects (0-3)."""
        return self.sfr[PSW] >> 3 & 3

    def r(self, n: int) -> int:
        """Register Rn of the active bank."""
        return self.iram[self.bank * 8 + n]

    def set_r(self, n: int, value: int) -> None:
        self.iram[self.bank * 8 + n] = value

    # -- helpers for traps ----------------------------------------------------------

    def push(self, value: int) -> None:
        """Push a byte as PUSH does (SP is incremented first)."""
        self.sfr[SP] = (self.sfr[SP] + 1) & 0xFF
        self.iram[self.sfr[SP]] = value

    def pop(self) -> int:
        value = self.iram[self.sfr[SP]]
        self.sfr[SP] = (self.sfr[SP] - 1) & 0xFF
        return value

    def ret(self) -> None:
        """Return to the caller as RET does, so a trap can stand in for a subroutine."""
        high = self.pop()
        self.pc = high << 8 | self.pop()

    # -- breakpoints and traps ------------------------------------------------------

    @property
    def breakpoints(self) -> frozenset[int]:
        return frozenset(self._breakpoints)

    def add_breakpoint(self, address: int) -> None:
        """Stop a run before the instruction at ``address`` (not the run's first one)."""
        self._breakpoints.add(address & 0xFFFF)
        self._stops_current = False

    def remove_breakpoint(self, address: int) -> None:
        self._breakpoints.discard(address & 0xFFFF)
        self._stops_current = False

    @property
    def traps(self) -> dict[int, Trap]:
        return dict(self._traps)

    def add_trap(self, address: int, trap: Trap) -> None:
        """Call ``trap(emulator)`` whenever the PC reaches ``address`` (see ``Trap``)."""
        self._traps[address & 0xFFFF] = trap
        self._stops_current = False

    def remove_trap(self, address: int) -> None:
        self._traps.pop(address & 0xFFFF, None)
        self._stops_current = False

    # -- execution ------------------------------------------------------------------

    def step(self) -> StopReason:
        """Execute one instruction (after any trap at the PC has run)."""
        return self.run(max_instructions=1)

    def run(
        self,
        max_instructions: int | None = None,
        max_cycles: int | None = None,
        until: int | None = None,
        trace: Callable[[Emulator, int], None] | None = None,
    ) -> StopReason:
        """Run until a budget is used up, a breakpoint or ``until`` is reached, or a trap
        asks to stop.

        Breakpoints and ``until`` stop *before* the instruction at their address, and are
        not checked for the first instruction of a run, so calling ``run`` again resumes.
        The cycle budget lets the last instruction finish: a run stops once at least
        ``max_cycles`` machine cycles have elapsed. ``trace(emulator, address)`` is called
        after every instruction and forces the interpreter.

        Raises :class:`UndefinedOpcode` with the PC at the A5h byte.
        """
        return self._run(max_instructions, max_cycles, until, trace)

    def prepare_call(self, address: int, return_address: int, stack: int) -> None:
        """Set up a call of the code at ``address`` from outside it, as the firmware calls
        a program cycle: register bank 0, ``return_address`` pushed onto the stack above
        ``stack`` as LCALL pushes it (low byte first), the PC at ``address``. The code's
        final RET then lands on ``return_address``."""
        sfr, iram = self.sfr, self.iram
        sfr[PSW] = 0
        iram[stack + 1 & 0xFF] = return_address & 0xFF
        iram[stack + 2 & 0xFF] = return_address >> 8
        sfr[SP] = stack + 2 & 0xFF
        self.pc = address

    def call(
        self,
        address: int,
        return_address: int,
        stack: int,
        max_cycles: int,
        trace: Callable[[Emulator, int], None] | None = None,
    ) -> StopReason:
        """``prepare_call``, then ``run(max_cycles=max_cycles, trace=trace)``: a run that
        ends at ``return_address`` when an ``exit_trap`` is there (TRAP).

        The common case is done in one step, as every program cycle of a simulation
        comes here: the code from ``address`` translated as one region that ends at the
        exit. Where the run is not that (a trace, no region yet, a breakpoint or trap in
        the way, a region longer than the budget), or the region ends elsewhere (a
        breakpoint, the budget, a trap), ``run``'s loop takes it on from there, so the
        answers are the same."""
        self.prepare_call(address, return_address, stack)
        block, _, most, kind = self._blocks.get(address, _STOP_ENTRY)  # bank 0: the key
        if (
            trace is not None
            or block is None
            or kind != _REGION
            or most > max_cycles  # as in ``_run``: a region must fit the budget
            or not self.translate
            or not self._stops_current
            or self._stops_until is not None
            or address in self._stops
        ):
            return self._run(None, max_cycles, None, trace)
        sfr = self.sfr  # PSW is 0: its parity bit needs no clearing before the region
        try:
            key = block(_UNLIMITED - self.instructions, max_cycles)
            iterations = self._iterations
            self.instructions += iterations[0]
            self.cycles += iterations[1]
            self.pc = pc = key & 0xFFFF
            if self._traps.get(pc) is exit_trap and iterations[1] < max_cycles:
                return _TRAP
            return self._run(None, max_cycles - iterations[1], None, None, first=False)
        finally:
            sfr[PSW] = sfr[PSW] & 0xFE | PARITY[sfr[ACC]]

    def _run(
        self,
        max_instructions: int | None,
        max_cycles: int | None,
        until: int | None,
        trace: Callable[[Emulator, int], None] | None,
        *,
        first: bool = True,
    ) -> StopReason:
        """``run``'s loop; ``first=False`` continues a run (breakpoints are checked at once)."""
        ilimit = _UNLIMITED if max_instructions is None else self.instructions + max_instructions
        climit = _UNLIMITED if max_cycles is None else self.cycles + max_cycles
        if until is not None:
            until &= 0xFFFF
        sfr = self.sfr
        sfr[PSW] &= 0xFE
        try:
            # as _stop_addresses answers, without the call while nothing changed (every run)
            stops = (self._stops if self._stops_current and until == self._stops_until
                     else self._stop_addresses(until))
            traps, blocks, iterations = self._traps, self._blocks, self._iterations
            interpret = trace is not None or not self.translate
            while True:
                pc = self.pc
                if not first and pc in stops and pc not in traps:
                    return _UNTIL if pc == until else _BREAKPOINT
                if self.instructions >= ilimit:
                    return _INSTRUCTIONS
                if self.cycles >= climit:
                    return _CYCLES_SPENT
                trap = traps.get(pc)
                if trap is not None:
                    first = False
                    if trap(self):
                        return _TRAP
                    sfr[PSW] &= 0xFE  # the trap may have set the parity bit
                    stops = self._stop_addresses(until)
                    if self.pc != pc:
                        continue
                # One instruction is not worth translating a block for (single-stepping).
                if interpret or pc in stops or ilimit - self.instructions == 1:
                    first = False
                    self._interpret_one()
                    if trace is not None:
                        trace(self, pc)
                    continue
                first = False
                # Translated code from here on, chained until a stop entry (then back to
                # the checks above) or until the budget is nearly spent (then the
                # interpreter finishes, instead of translating blocks at every remaining
                # address). Inline, not a method: every program cycle comes through here.
                icount, ccount = self.instructions, self.cycles
                key = pc | (sfr[PSW] & 24) << 13
                try:
                    while True:
                        entry = blocks.get(key)
                        if entry is None:
                            entry = self._translate(key)
                        block, n, cycles, kind = entry
                        if block is None:
                            break
                        if kind == _WARM:
                            block, n, cycles, kind = self._warm(key)
                        if kind == _REGION:
                            if icount + n <= ilimit and ccount + cycles <= climit:
                                key = block(ilimit - icount, climit - ccount)
                                icount += iterations[0]
                                ccount += iterations[1]
                                continue
                            block, n, cycles, kind = (self._plain.get(key)
                                                      or self._translate_block(key))
                        if kind == _LOOP:
                            allowed = min((ilimit - icount) // n, (climit - ccount) // cycles)
                            if allowed < 1:
                                interpret = True
                                break
                            key = block(allowed)
                            icount += n * iterations[0]
                            ccount += cycles * iterations[0]
                            continue
                        if icount + n > ilimit or ccount + cycles > climit:
                            interpret = True
                            break
                        key = block()
                        icount += n
                        ccount += cycles
                finally:
                    self.pc = key & 0xFFFF
                    self.instructions, self.cycles = icount, ccount
        finally:
            sfr[PSW] = sfr[PSW] & 0xFE | PARITY[sfr[ACC]]

    def _stop_addresses(self, until: int | None) -> frozenset[int]:
        # Breakpoints and traps change rarely; a cycle's run and a trap's return ask often.
        if self._stops_current and until == self._stops_until:
            return self._stops
        stops = frozenset(self._breakpoints | self._traps.keys())
        if until is not None:
            stops |= {until}
        if stops != self._stops:
            self._stops = stops
            self._invalidate()
        self._stops_until, self._stops_current = until, True
        return stops

    def _interpret_one(self) -> None:
        pc = self.pc
        opcode = self.code[pc]
        handler = self._handlers[opcode]
        if handler is None:
            raise UndefinedOpcode(pc)
        self.pc = handler(pc)
        self.instructions += 1
        self.cycles += _CYCLES[opcode]

    @property
    def regions(self) -> bool:
        """Translate whole regions (regions.py), not only blocks: the fast path."""
        return self._regions

    @regions.setter
    def regions(self, value: bool) -> None:
        self._regions = value
        self._invalidate()

    def _invalidate(self) -> None:
        self._blocks.clear()
        self._plain.clear()
        self._heat.clear()

    def _translate(self, key: int) -> Entry:
        pc = key & 0xFFFF
        if pc in self._stops:
            entry = _STOP_ENTRY
        elif self.code[pc] == UNDEFINED_OPCODE:
            entry = (_undefined_block(pc), 1, 0, _BLOCK)
        else:
            entry = self._translate_block(key)
            if self._regions:
                entry = (entry[0], entry[1], entry[2], _WARM)
        self._blocks[key] = entry
        return entry

    def _warm(self, key: int) -> Translated:
        """The code to run for a warm block: the block, or its region once it is hot."""
        heat = self._heat[key] = self._heat.get(key, 0) + 1
        plain = self._plain[key]
        if heat < self.hot:
            return plain
        region = build_region(self.code, key & 0xFFFF, key >> 13 & 24, self._stops)
        source = f"{_FACTORY_HEADER}{region.source}\n    return region\n"
        entry = (_instantiate(source, self), region.instructions, region.cycles, _REGION)
        self._blocks[key] = entry
        return entry

    def _translate_block(self, key: int) -> Translated:
        """The block at ``key`` (neither a stop nor an undefined opcode)."""
        pc, bank = key & 0xFFFF, key >> 13 & 24
        code = self.code
        writer = Writer(static=True, bank=bank)
        address, count, cycles = pc, 0, 0
        while True:
            info = OPCODES[code[address]]
            assert info is not None  # the block ends before an undefined opcode
            raw = bytes(code[(address + k) & 0xFFFF] for k in range(info.length))
            writer.instruction(info, address, raw)
            count += 1
            cycles += info.cycles
            address = (address + info.length) & 0xFFFF
            if (
                writer.ended
                or writer.bank_changes
                or count == MAX_BLOCK
                or address in self._stops
                or OPCODES[code[address]] is None
            ):
                break
        loops = writer.loops_to(pc)
        body = writer.finish(
            "block", address if writer.falls_through else None, pc if loops else None
        )
        source = f"{_FACTORY_HEADER}{body}\n    return block\n"
        block: Callable[..., int] = _instantiate(source, self)
        entry = (block, count, cycles, _LOOP if loops else _BLOCK)
        self._plain[key] = entry
        return entry


__all__ = [
    "PARITY",
    "Emulator",
    "EmulatorError",
    "StopReason",
    "Trap",
    "UndefinedOpcode",
]
