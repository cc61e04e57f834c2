"""The emulated AS-i PC2 board: three I/O registers in front of a master with AS-i Control.

The host sees only what the ISA card shows (manual 7.2): a data register, INDEX and PAGE.
Behind them are the board's parts: the DPRAM (``dpram``), which is also the XDATA RAM the
control program runs on, the master's execution control (``execution``), AS-i Control
(``control``) with the firmware blocks (``services``), the images the master writes into
the DPRAM (``images``) and the host commands (``commands``). This module owns the
registers, the composition, and time: master time is virtual and moves only in
``advance``.

Speed: ``advance`` jumps over stretches in which nothing can change. An AS-i cycle with no
host access, no bus change and no due timer does nothing but the program cycle, and a
program cycle that left the whole machine state (internal RAM, SFRs, XDATA) as it found
it, calling no firmware block, will do so again until something external changes: such
cycles are skipped, and so are AS-i cycles with nothing left to do. The 10 ms ticks of
running timers whose remaining time the program never reads (the image says which) change
only that time until one runs out: an idle board counts them down in one step, to the
tick before the first runs out, unless someone watches a timer's remaining time
(``tick_exactly``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from asictl.board.asi import AsiBus
from asictl.board.commands import HostCommands
from asictl.board.control import AsiControl
from asictl.board.dpram import COMMAND, MASTER_OWNED, Dpram
from asictl.board.execution import ExecutionControl, Phase
from asictl.board.forcing import Area
from asictl.board.images import VERSION_ID, MasterImages
from asictl.board.nonvolatile import Nonvolatile
from asictl.board.services import MasterFirmware
from asictl.image.eeprom import ProgramImage, image_length
from asictl.mcs51.emulator import EmulatorError, UndefinedOpcode
from asictl.platform import pc2 as d
from asictl.platform.master import (
    COUNTER_HIGH_FLAGS,
    SLAVES,
    TICK_US,
    ControlFlag,
    asi_cycle_us,
)
from asictl.platform.pc2 import ControlState, HiFlag, InterruptSource, StopReason, nibbles
from asictl.runtime import layout
from asictl.runtime.runner import CycleTimeout, ProgramRunner

#: The ODI is stored inverted (manual 7.3).
_INVERT = bytes(255 - b for b in range(256))
_ASI_CYCLE = int(InterruptSource.ASI_CYCLE)
_NO_OUTPUTS = bytes(16)
#: The DPRAM addresses of the mapped counters' high bytes (map_counters).
_COUNTER_HIGH_BYTES = frozenset(d.FLAGS + n for n in COUNTER_HIGH_FLAGS)
# Looked up every AS-i cycle: plain module constants.
_WATCHDOG_ENABLE = d.WATCHDOG_ENABLE
_INTERRUPT_ENABLE = d.INTERRUPT_ENABLE
_NORMAL = Phase.NORMAL
_MAP_COUNTERS = int(ControlFlag.MAP_COUNTERS)
_NO_STOP = StopReason.NONE
#: At most this many program cycles run unprobed between two busy probes (``_quiet``).
_PROBE_GAP = 16


class Pc2Board:
    """One PC2 board with its AS-i cable; see docs/master.md for what is modelled."""

    #: called after every AS-i cycle that ran (not after the ones skipped as idle)
    observer: Callable[[], None] | None = None
    #: whether ``advance`` runs steady AS-i cycles through ``_steady_cycles`` (False:
    #: every cycle through ``_cycle``, which tests hold the steady path against)
    steady_path = True
    #: told how many program cycles did not run because each would have repeated the
    #: last one exactly (exact coverage counts, observe/coverage.py); while it is set, a
    #: program that takes longer than an AS-i cycle is never taken for a repeating one,
    #: so that each AS-i cycle skipped is one program cycle
    repeated: Callable[[int], None] | None = None
    _cycle_period_us: int | None = None
    _pause: bool = False

    def __init__(self, *, bus: AsiBus | None = None) -> None:
        self._boot(Nonvolatile(bus=bus if bus is not None else AsiBus()), now_us=0)

    @classmethod
    def from_nonvolatile(cls, data: dict[str, Any]) -> Pc2Board:
        """Power up with the state ``nonvolatile`` saved; ``NonvolatileError`` if malformed."""
        board = cls.__new__(cls)
        board._boot(Nonvolatile.from_json(data), now_us=0)
        return board

    def nonvolatile(self) -> dict[str, Any]:
        """What survives power-off, JSON-able: EEPROM, settings, and the installation's slaves."""
        return self._nonvolatile_state().to_json()

    def _nonvolatile_state(self) -> Nonvolatile:
        ec = self._ec
        return Nonvolatile(
            eeprom=bytes(self._eeprom),
            control_flags=self._control.flags,
            configuration_mode=ec.configuration_mode,
            lps=ec.lps,
            los=ec.los,
            pcd=bytes(ec.pcd),
            pp=bytes(ec.pp),
            config_ok_delay=ec.config_ok_delay,
            bus=self.bus,
            forced=self.forces,
        )

    # ------------------------------------------------------------------ power-up

    def _boot(self, state: Nonvolatile, *, now_us: int) -> None:
        """Power-up: the DPRAM is written anew, everything volatile starts from scratch."""
        self.bus = bus = state.bus
        #: the force list (board/forcing.py); change it through ``force`` and ``release``
        self.forces = state.forced
        #: whether anything is forced: the cycle looks at this plain flag alone otherwise
        self._forcing = bool(self.forces)
        self._now_us = self._power_up_us = now_us
        self._index = self._page = 0
        self._in_reset = False
        self._saved: Nonvolatile | None = None
        self._dpram = dpram = Dpram()
        self._ram = dpram.ram
        self._eeprom = bytearray(state.eeprom)
        self._ec = ExecutionControl(
            bus,
            configuration_mode=state.configuration_mode,
            lps=state.lps,
            pcd=state.pcd,
            pp=state.pp,
            los=state.los,
            config_ok_delay=state.config_ok_delay,
        )
        self._firmware = MasterFirmware(self._ec, self._eeprom, VERSION_ID)
        self._control = AsiControl(dpram.xdata, self._firmware, state.control_flags)
        self._images = images = MasterImages(dpram, self._ec, self._control)
        self._commands = HostCommands(
            self, dpram, self._ec, self._control, self._eeprom, images
        )
        self._host_outputs = _NO_OUTPUTS
        self._host_dirty = False
        self._command_pending = False
        self._odi_sent: bytes | None = None  # the outputs the ODI holds, inverted
        self._program_ready_us = 0
        #: per timer of the program, its address and whether its ticks may be counted
        #: down in one step (nobody reads its remaining time)
        self._timer_places: list[tuple[int, bool]] = []
        self._exact_timers: set[int] = set()
        #: the last quiet cycle's starting state, and whether the one before it started
        #: from the same state but for the remaining times of the running unread timers
        self._seen: bytes | None = None
        self._leap_ok = False
        self._quiet = False
        #: program cycles until the next one is probed for a fixed point, and the gap
        #: after the last busy probe (it doubles while the probes find the program busy)
        self._probe_wait = 0
        self._probe_gap = 0
        for slave in bus:
            slave.outputs = 0
        images.write_identity()
        self._ram[d.ODI : d.ODI + d.IMAGE_SIZE] = b"\xff" * d.IMAGE_SIZE
        images.write_config_ok_delay()
        self.reload_program()
        images.write_settings()
        images.write_lists()  # and the status bytes with them
        images.write_control_flags()
        self._next_cycle_us = now_us + self._period()
        self._next_tick_us = now_us + TICK_US

    def reload_program(self) -> bool:
        """Load the program from the EEPROM (power-up, command 50's reset bit)."""
        eeprom = bytes(self._eeprom)
        loaded = self._control.load(eeprom)
        self._copied = (self._now_us, image_length(eeprom))
        self._place_timers()
        self._quiet = False
        self._dpram.stirred = True
        return loaded

    def tick_exactly(self, timers: set[int]) -> None:
        """Count these timers down tick by tick even where the program never reads their
        remaining time: an observer samples it after the cycles that run (a trace, a
        tolerance window, a plant rule), and a step over many ticks would hide the
        values between."""
        self._exact_timers = set(timers)
        self._place_timers()

    def _place_timers(self) -> None:
        runner = self._control.runner
        pmap = runner.pmap if runner is not None else None
        self._timer_places = [] if pmap is None else [
            (address, n in pmap.unread_timers and n not in self._exact_timers)
            for n, address in sorted(pmap.timers.items())
        ]
        self._unread_addresses = sorted(a for a, unread in self._timer_places if unread)
        self._seen, self._leap_ok = None, False

    # ------------------------------------------------------------------ the port

    def io_read(self, offset: int) -> int:
        """Offset 0 reads the DPRAM byte at PAGE:INDEX; 1 and 2 are write-only (read FFh)."""
        if offset == d.PORT_DATA:
            value = self._ram[self._page << 8 | self._index]
            self._step_index()
            return value
        if offset in (d.PORT_INDEX, d.PORT_PAGE):
            return 0xFF
        raise ValueError(f"the PC2 board decodes I/O offsets 0..2, not {offset}")

    def io_write(self, offset: int, value: int) -> None:
        if not 0 <= value <= 0xFF:
            raise ValueError(f"an I/O write carries one byte, not {value}")
        if offset == d.PORT_DATA:
            address = self._page << 8 | self._index
            kind = self._dpram.host_write(address, value)
            if address in _COUNTER_HIGH_BYTES and self._counters_mapped():
                self._ram[address] &= 0x0F
            self._host_dirty = True
            if kind == COMMAND:
                self._command_pending = value not in (d.ACK, d.NAK)
            elif kind == MASTER_OWNED:
                self._images.host_overwrote_lists()
            self._step_index()
        elif offset == d.PORT_INDEX:
            self._index = value
        elif offset == d.PORT_PAGE:
            self._page = value & d.PAGE_MASK
            if value & d.PAGE_RESET_BIT and not self._in_reset:
                self._hold_reset()
            elif not value & d.PAGE_RESET_BIT and self._in_reset:
                assert self._saved is not None  # set by _hold_reset
                self._boot(self._saved, now_us=self._now_us)
        else:
            raise ValueError(f"the PC2 board decodes I/O offsets 0..2, not {offset}")

    def _step_index(self) -> None:
        """INDEX counts up; after byte 255 of a page both INDEX and PAGE start again at 0."""
        if self._index == 0xFF:
            self._index = self._page = 0
        else:
            self._index += 1

    def _hold_reset(self) -> None:
        """PAGE bit 4: the board stops; the slaves, no longer called, switch off."""
        self._saved = self._nonvolatile_state()
        self._in_reset = True
        for slave in self.bus:
            slave.outputs = 0

    # ------------------------------------------------------------------ time

    @property
    def next_tick_us(self) -> int:
        """Master time of the next 10 ms tick (the clock's phase, for the prover's
        counterexamples)."""
        return self._next_tick_us

    def move_next_tick(self, at_us: int) -> None:
        """The next 10 ms tick at ``at_us`` (within the next 10 ms), and every 10 ms after
        it: the clock's phase, which runs on its own on a real master, as a scenario
        that depends on it asks (``first_tick_ms``)."""
        if not self._now_us < at_us <= self._now_us + TICK_US:
            raise ValueError(f"the next tick is within 10 ms from now, not at {at_us} us")
        self._next_tick_us = at_us

    @property
    def now_us(self) -> int:
        return self._now_us

    @property
    def now_ms(self) -> float:
        return self._now_us / 1000

    def advance(self, ms: float) -> None:
        """Let ``ms`` of master time pass: AS-i cycles, program cycles, 10 ms ticks, commands."""
        if ms < 0 or not math.isfinite(ms):
            raise ValueError(f"time only moves forward: advance({ms})")
        end = self._now_us + round(ms * 1000)
        if self._in_reset:
            self._now_us = end
            self._next_cycle_us = end + self._period()
            self._next_tick_us = end + TICK_US
            return
        while True:
            if self.steady_path and self._steady_cycles(end):
                return
            tick, cycle = self._next_tick_us, self._next_cycle_us
            now = tick if tick < cycle else cycle
            if now > end:
                break
            self._now_us = now
            if now == tick:
                self._tick()
                self._next_tick_us = tick + TICK_US
            if now == cycle:
                self._cycle()
                if self._after_cycle(now, end):
                    return
        self._now_us = end

    def _after_cycle(self, now: int, end: int) -> bool:
        """After the AS-i cycle at ``now``: the observer, then when the next cycle comes
        (idle cycles skipped). Returns whether the observer paused ``advance``."""
        observer = self.observer
        if observer is not None:
            observer()
        return self._schedule(now, end)

    def _schedule(self, now: int, end: int) -> bool:
        """When the next AS-i cycle after the one at ``now`` comes: the next period, or
        after the idle cycles skipped; at once when the observer paused (True)."""
        period = self._cycle_period_us or self._period()
        if self._pause:  # the observer has news for the caller: no cycle skipped
            self._pause = False
            self._next_cycle_us = now + period
            self._now_us = now
            return True
        skip = self._idle_cycles(now, period, end) if self._idle() else 0
        if skip:
            self._ec.count_idle_cycles(skip)
            if self.repeated is not None and self._control.running:
                self.repeated(skip)
        self._next_cycle_us = now + (skip + 1) * period
        return False

    def pause(self) -> None:
        """From the observer: ``advance`` returns after this AS-i cycle, master time at
        the cycle, so that its caller can act before the next one (a simulation's plant
        model that will change an input sooner than the caller planned for)."""
        self._pause = True

    def _period(self) -> int:
        """The AS-i cycle: fixed, or by the number of active slaves (``asi_cycle_us``)."""
        if self._cycle_period_us is not None:
            return self._cycle_period_us
        return asi_cycle_us(self._ec.active_count)

    @property
    def cycle_period_us(self) -> int | None:
        """A fixed AS-i cycle time in microseconds instead of the slave-count rule (None)."""
        return self._cycle_period_us

    @cycle_period_us.setter
    def cycle_period_us(self, value: int | None) -> None:
        if value is not None and (not isinstance(value, int) or value <= 0):
            raise ValueError(f"an AS-i cycle lasts a positive number of microseconds, not {value}")
        self._cycle_period_us = value

    def _steady_cycles(self, end: int) -> bool:
        """The AS-i cycles up to ``end`` (and the ticks among them) for as long as each is
        the steady case: a running program that may go on and is not probed, a settled
        execution control, no host access and nothing forced. Then an AS-i cycle is the
        data exchange, the program cycle and the ASI-cycle interrupt, which this does
        without asking the rest of ``_cycle``'s questions (tests/board/test_board_steady.py
        holds it equal to ``_cycle``). Returns at the first cycle that is not steady,
        before doing any of its work; True when the observer paused ``advance``.

        What may stop a running program (``AsiControl.blocker``) is not asked: it changes
        only with a command (the control flags) or a step of the execution control (its
        phase, the configuration check), and a cycle with either goes through ``_cycle``,
        which asks after them; a stop of its own (a fault) ends ``running``."""
        while True:
            tick, cycle = self._next_tick_us, self._next_cycle_us
            if tick <= cycle:  # a tick at a cycle's time comes first, as in ``advance``
                if tick > end:
                    return False
                self._now_us = tick
                self._tick()
                self._next_tick_us = tick + TICK_US
                continue
            if cycle > end:
                return False
            control, ec = self._control, self._ec
            runner = control.runner
            if (
                runner is None
                or not control.running
                or not self._probe_wait
                or self._quiet
                or self._host_dirty
                or self._command_pending
                or self._forcing
                or cycle < self._program_ready_us
                or not ec.settled
            ):
                return False
            self._now_us = cycle
            dpram = self._dpram
            self._images.update()
            if ec.exchange(runner.outputs):
                dpram.put(d.IDI, ec.idi)
                dpram.interrupt(InterruptSource.IDI_CHANGE)
            dpram.stirred = False
            try:
                runner.cycle(ec.idi)
            except Exception as exc:  # as in ``_program_cycle``
                self._program_failed(exc)
            else:
                if control.flags & _MAP_COUNTERS:
                    self._after_program(runner, None, 0)
                else:  # ``_after_program`` without a probe or counters (nothing forced here)
                    duration = control.record_cycle(runner.last_cycles)
                    self._program_ready_us = cycle + math.ceil(duration)
                    self._probe_wait -= 1
                    self._seen, self._leap_ok = None, False
                    self._write_odi(runner.outputs)
                    self._images.update_settings()
            if self._ram[_INTERRUPT_ENABLE] & _ASI_CYCLE and ec.phase is _NORMAL:
                dpram.interrupt(InterruptSource.ASI_CYCLE)
            observer = self.observer  # ``_after_cycle``, the common case without calls
            if observer is not None:
                observer()
            if self._pause or not control.running:
                if self._schedule(cycle, end):
                    return True
            else:  # running and not quiet (as this loop requires): not idle
                self._next_cycle_us = cycle + (self._cycle_period_us or self._period())

    def _idle(self) -> bool:
        """Would the next AS-i cycle change nothing? Then so would all until the next tick."""
        return not (
            (self._control.running and (not self._quiet or self._dpram.stirred))
            or self._host_dirty
            or self._command_pending
            or not self._ec.settled
            or not self._ec.in_step(self._outputs())
        )

    def _idle_cycles(self, now: int, period: int, end: int) -> int:
        """How many AS-i cycles after ``now`` can be skipped, and skip the ticks among them.

        Cycles before the next tick can always go; so can those before the first tick
        that changes something the program could tell (``_quiet_ticks``), up to ``end``.
        """
        quiet = self._quiet_ticks()
        limit = end if quiet is None else min(end, self._next_tick_us + quiet * TICK_US - 1)
        skip = max(0, (limit - now) // period)
        last = now + skip * period
        if self._next_tick_us <= last:
            ticks = (last - self._next_tick_us) // TICK_US + 1
            self._next_tick_us += ticks * TICK_US
            if quiet is not None:  # unread timers run: they count down as the ticks would
                self._count_down(ticks)
        return skip

    def _quiet_ticks(self) -> int | None:
        """How many of the coming ticks change nothing a program cycle could tell: all
        (None) with the watchdog off and no program timer running; with only timers
        running whose remaining time nobody reads, those before the first runs out (its
        status bit changes with that tick); else none."""
        ram = self._ram
        if ram[_WATCHDOG_ENABLE]:
            return 0
        if not self._control.running:
            return None
        least: int | None = None
        for address, unread in self._timer_places:
            remaining = ram[address] | ram[address + 1] << 8
            if remaining:
                if not unread or not self._leap_ok:
                    return 0
                least = remaining if least is None else min(least, remaining)
        return None if least is None else least - 1

    def _count_down(self, ticks: int) -> None:
        """``ticks`` ticks of the program's timers at once (none of them runs out)."""
        runner = self._control.runner
        if runner is None:
            return
        try:
            runner.tick(ticks)
        except Exception as exc:  # as in ``_tick``: never out of ``advance``
            self._halt(StopReason.PROGRAM_FAULT, _fault(exc))
        self._dpram.stirred = True

    def _tick(self) -> None:
        """The 10 ms clock: watchdog, program timers."""
        ram = self._ram
        if ram[_WATCHDOG_ENABLE]:
            count = ram[d.WATCHDOG_COUNTER]
            if count:
                count -= 1
                ram[d.WATCHDOG_COUNTER] = count
                self._dpram.stirred = True
            if not count:  # time-out: offline until the host clears the offline flag
                ram[d.WATCHDOG_ENABLE] = 0
                ram[d.HI_FLAGS] |= HiFlag.OFFLINE
                self._read_host_flags()
                self._images.write_status()  # the W/w and O/o letters change with it
        runner = self._control.runner
        if self._control.running and runner is not None:
            try:
                if runner.tick():  # a tick of stopped timers changes nothing
                    self._dpram.stirred = True
            except Exception as exc:  # as in a program cycle: never out of ``advance``
                self._halt(StopReason.PROGRAM_FAULT, _fault(exc))
                self._dpram.stirred = True

    # ------------------------------------------------------------------ the AS-i cycle

    def _cycle(self) -> None:
        """One AS-i cycle: host images and commands, execution control, data, program."""
        ec = self._ec
        if self._host_dirty:
            self._read_host_images()
        if self._command_pending:
            self.answer_command()
        if not ec.settled:  # a settled execution control has nothing to do
            ec.step(self._now_us)
        self._images.update()
        control = self._control
        if not control.running or control.blocker(
                normal=ec.phase is _NORMAL, config_ok=ec.config_ok) is not _NO_STOP:
            self._update_control()  # a running program that may go on is the common case
        if ec.exchange(self._outputs()):
            self._dpram.put(d.IDI, ec.idi)
            self._dpram.interrupt(InterruptSource.IDI_CHANGE)
        if self._forcing:  # a host's write to a forced flag never reaches the program
            self.forces.rewrite_flags(self._ram, d.FLAGS)
        if control.running and self._now_us >= self._program_ready_us:
            self._program_cycle()
        if self._ram[_INTERRUPT_ENABLE] & _ASI_CYCLE and ec.phase is _NORMAL:
            self._dpram.interrupt(InterruptSource.ASI_CYCLE)

    def answer_command(self, *, run: bool = True) -> None:
        """Answer the command the host wrote: run it (00h, or FFh if refused), or refuse
        it unrun (``run=False``). The AS-i cycle does this; a live board held at a
        breakpoint does it at once, since no cycle comes while the master stands still."""
        self._command_pending = False
        ok = run and self._commands.run(self._ram[d.COMMAND])
        self._ram[d.COMMAND] = d.ACK if ok else d.NAK

    def _outputs(self) -> bytes | bytearray:
        """What the slaves receive: the program's outputs (the host's while it is
        stopped), forced bits in place."""
        runner = self._control.runner
        outputs = (runner.outputs if self._control.running and runner is not None
                   else self._host_outputs)
        return self.forces.outputs(outputs) if self._forcing else outputs

    def _read_host_images(self) -> None:
        """The images the master reads cyclically: ODI, PI, hi-flags, and its settings."""
        self._host_dirty = False
        ram, ec = self._ram, self._ec
        odi = bytes(ram[d.ODI : d.ODI + d.IMAGE_SIZE])
        if self._control.running:
            if odi.translate(_INVERT) != self._odi_sent:
                self._odi_sent = None  # the program's outputs overwrite the host's
        else:
            self._host_outputs = odi.translate(_INVERT)
        pi = nibbles(ram[d.PI : d.PI + d.IMAGE_SIZE])
        for a in range(SLAVES):
            if pi[a] != ec.pi[a]:
                ec.write_parameter(a, pi[a])
        self._read_host_flags()
        ec.config_ok_delay = ram[d.CONFIG_OK_DELAY]
        self._images.write_status()

    def _read_host_flags(self) -> None:
        hi = self._ram[d.HI_FLAGS]
        self._ec.set_host_flags(
            data_exchange_active=not hi & HiFlag.DATA_EXCHANGE_OFF,
            offline=bool(hi & HiFlag.OFFLINE),
            auto_address_enable=not hi & HiFlag.AUTO_ADDRESS_OFF,
        )

    def _update_control(self) -> None:
        control, ec = self._control, self._ec
        blocker = control.blocker(normal=ec.phase is _NORMAL, config_ok=ec.config_ok)
        if control.running:
            if blocker is _NO_STOP:
                return
            control.stop(blocker)
            self.safe_outputs()
        elif blocker is _NO_STOP:
            control.start()
            self._program_ready_us = self._now_us
            self._dpram.stirred = True
        else:
            control.reason = blocker
        self._images.write_status()

    def _program_cycle(self) -> None:
        control, dpram = self._control, self._dpram
        runner = control.runner
        if runner is None:
            return
        if self._quiet and not dpram.stirred:
            if self.repeated is not None:
                self.repeated(1)
            return
        dpram.stirred = False
        probe = self._probe_wait == 0
        calls = self._firmware.calls
        before = self._snapshot(runner) if probe else None
        try:
            runner.cycle(self.forces.inputs(self._ec.idi) if self._forcing else self._ec.idi)
        except Exception as exc:  # whatever the program did, the master carries on
            self._program_failed(exc)
            return
        self._after_program(runner, before, calls)

    def _program_failed(self, exc: Exception) -> None:
        """The program cycle raised ``exc``: the master stops the program."""
        if isinstance(exc, CycleTimeout):
            self._halt(StopReason.CYCLE_TIMEOUT, str(exc))
            return
        if isinstance(exc, UndefinedOpcode):
            self._dpram.put(d.STOP_ADDRESS, exc.pc.to_bytes(2, "little"))  # the host's line
        self._halt(StopReason.PROGRAM_FAULT, _fault(exc))

    def _after_program(self, runner: ProgramRunner, before: bytes | None, calls: int) -> None:
        """After a program cycle that ran to its end: the cycle time, the fixed-point probe
        (``before``: the state a probe found before the cycle, ``calls``: the firmware
        calls counted then), the outputs into the ODI."""
        control = self._control
        if control.flags & _MAP_COUNTERS:
            ram = self._ram
            for address in _COUNTER_HIGH_BYTES:
                ram[address] &= 0x0F
        if self._forcing:  # before the quiet check: a held flag is no change
            self.forces.rewrite_flags(self._ram, d.FLAGS)
        duration = control.record_cycle(runner.last_cycles)
        self._program_ready_us = self._now_us + math.ceil(duration)
        if before is not None:
            self._quiet = calls == self._firmware.calls and self._unchanged(runner, before) \
                and (self.repeated is None or math.ceil(duration) <= self._period())
            # A program that settles soon after a change (a blinker's toggle) is probed
            # again soon; one busy every cycle only every _PROBE_GAP cycles: a probe
            # copies and compares 32 KB.
            self._probe_gap = 0 if self._quiet else min(_PROBE_GAP, 2 * self._probe_gap + 1)
            self._probe_wait = self._probe_gap
            if self._unread_addresses:
                self._note_quiet(runner, before if self._quiet else None)
        else:
            self._probe_wait -= 1
            self._quiet = False
            self._seen, self._leap_ok = None, False
        self._write_odi(self.forces.outputs(runner.outputs) if self._forcing else runner.outputs)
        self._images.update_settings()

    def _write_odi(self, sent: bytes | bytearray) -> None:
        """The outputs the slaves get into the ODI (inverted), when they changed (compared
        as they are: inverting them first cost every program cycle a new bytes object)."""
        if sent != self._odi_sent:
            self._odi_sent = bytes(sent)
            self._dpram.put(d.ODI, sent.translate(_INVERT))

    def _halt(self, reason: StopReason, detail: str) -> None:
        """The firmware stops a program that cannot go on: outputs to the safe state."""
        self._control.stop(reason, detail)
        self.safe_outputs()
        self._images.write_status()

    @staticmethod
    def _snapshot(runner: ProgramRunner) -> bytes:
        """The program's state: the 8051's memories, and the input image the next cycle
        copies into I2 when the program reads I2 (an input change reaches I2 one cycle
        after I, so a cycle that changed only that image still changes the next one)."""
        cpu = runner.cpu
        inputs = runner.inputs if runner.reads_previous_inputs else b""
        # joined in one copy (XDATA's 32 KB are the bulk of it)
        return b"".join((cpu.iram, cpu.sfr, inputs,
                         memoryview(cpu.xdata.ram)[: layout.DATA_LIMIT]))

    def _note_quiet(self, runner: ProgramRunner, snapshot: bytes | None) -> None:
        """May the ticks of the running unread timers be counted down in one step? Only
        after two quiet cycles from one state but for those timers' remaining times,
        which differed in each: a cycle's writes cannot depend on a time it never reads,
        and it writes a timer's time only as a whole word (S T, R T, T T), so a cycle
        that left two different times as they were writes none of them; it would leave
        every time until the first runs out as it was (``ProgramMap.unread_timers``)."""
        previous, self._seen, self._leap_ok = self._seen, snapshot, False
        if snapshot is None or previous is None or len(previous) != len(snapshot):
            return
        offset = self._xdata_at(runner)
        start = 0
        for address in self._unread_addresses:
            at = offset + address
            if snapshot[at] or snapshot[at + 1]:  # running: its time must differ
                if previous[start:at] != snapshot[start:at] or \
                        previous[at : at + 2] == snapshot[at : at + 2]:
                    return
                start = at + 2
        self._leap_ok = start > 0 and previous[start:] == snapshot[start:]

    @staticmethod
    def _xdata_at(runner: ProgramRunner) -> int:
        """Where XDATA starts in a ``_snapshot``: after internal RAM, the SFRs and the
        input image when it is part of the state."""
        return 512 + (len(runner.inputs) if runner.reads_previous_inputs else 0)

    @classmethod
    def _unchanged(cls, runner: ProgramRunner, snapshot: bytes) -> bool:
        """Is the machine as ``_snapshot`` found it? (Compared in place: no copy of XDATA.)"""
        cpu = runner.cpu
        if runner.reads_previous_inputs and not snapshot.startswith(runner.inputs, 512):
            return False
        return (
            snapshot.startswith(cpu.iram)
            and snapshot.startswith(cpu.sfr, 256)
            and cpu.xdata.ram.startswith(memoryview(snapshot)[cls._xdata_at(runner):])
        )

    def safe_outputs(self) -> None:
        """Program stopped: outputs 0 until the host writes the ODI (stored inverted)."""
        self._host_outputs = _NO_OUTPUTS
        self._odi_sent = None
        self._dpram.put(d.ODI, b"\xff" * d.IMAGE_SIZE)

    # ------------------------------------------------------------------ forcing

    def force(self, area: Area, index: int, mask: int, bits: int) -> None:
        """Hold the bits under ``mask`` at ``bits`` (board/forcing.py says where); a
        forced flag is written at once. ``ForceError`` for an index or mask out of range."""
        self.forces.force(area, index, mask, bits)
        self._forces_changed()

    def release(self, area: Area | None = None, index: int = 0, mask: int = 0) -> int:
        """Release the bits under ``mask`` of ``index`` (all forces: ``area`` None);
        returns how many were released (indices for all, else 1 or 0)."""
        if area is None:
            released = self.forces.clear()
        else:
            released = int(self.forces.release(area, index, mask))
        self._forces_changed()
        return released

    def _forces_changed(self) -> None:
        """The next AS-i cycle runs the program and sends the outputs again."""
        self._forcing = bool(self.forces)
        self.forces.rewrite_flags(self._ram, d.FLAGS)
        self._dpram.stirred = True
        self._quiet = False
        self._host_dirty = True
        self._odi_sent = None

    # ------------------------------------------------------------------ buttons and views

    def press_set_button(self) -> None:
        """The set button: a program stopped with "wait for set button" may start again."""
        self._control.press_set_button()

    def diagnostics(self) -> tuple[int, bytes]:
        """The LCS and the slaves' error counters as they stand, without clearing them
        (commands 70 and 71 read and clear; a monitor only looks)."""
        return self._ec.lcs, bytes(self._ec.error_counters)

    @property
    def dpram(self) -> bytes:
        return self._dpram.snapshot()

    def dpram_byte(self, address: int) -> int:
        """One byte of the DPRAM, without the copy of all 1 KB that ``dpram`` makes (for
        those who look at one byte often: a command's acknowledge, a flag)."""
        if not 0 <= address < d.DPRAM_SIZE:
            raise IndexError(f"DPRAM address {address:X}h is outside 000h-3FFh")
        return self._ram[address]

    @property
    def pointer(self) -> int:
        """The DPRAM address INDEX and PAGE point at: where the next data access goes.
        The host cannot read the registers back, but whoever shares one board between
        several hosts (the live board's clients) keeps each one's pointer by it."""
        return self._page << 8 | self._index

    @property
    def eeprom(self) -> bytes:
        return bytes(self._eeprom)

    @property
    def phase(self) -> Phase:
        return self._ec.phase

    @property
    def mode(self) -> str:
        return "configuration" if self._ec.configuration_mode else "protected"

    @property
    def execution(self) -> ExecutionControl:
        """The execution control (lists, LCS, error counters) for tests and status views."""
        return self._ec

    @property
    def control_state(self) -> ControlState:
        return self._control.state

    @property
    def running(self) -> bool:
        """Does the control program run? (``control_state`` is RUNNING; asked after
        every cycle, without building the enum.)"""
        return self._control.running

    @property
    def stop_reason(self) -> StopReason:
        return self._control.reason

    @property
    def stop_message(self) -> str:
        """Why the control program is not running, in words (the time-out's own message)."""
        return self._control.message

    @property
    def control_flags(self) -> ControlFlag:
        return ControlFlag(self._control.flags_byte())

    def _counters_mapped(self) -> bool:
        return bool(self._control.flags & _MAP_COUNTERS)  # an int: asked every cycle

    @property
    def program_status(self) -> d.ProgramStatus:
        return self._control.program_status

    @property
    def program_error(self) -> str:
        return self._control.load_error

    @property
    def program(self) -> ProgramRunner | None:
        """The loaded program's runner (whether or not it runs)."""
        return self._control.runner

    @property
    def loaded_image(self) -> ProgramImage | None:
        """The image the last load found valid (its identity names the running program)."""
        return self._control.image

    @property
    def outputs(self) -> bytes:
        """The output image the master sends to the slaves now (not inverted)."""
        return bytes(self._outputs())

    @property
    def cycle_times_us(self) -> tuple[float, float]:
        """The last and the longest program cycle since loading, in microseconds."""
        return self._control.previous_us, self._control.maximum_us

    @property
    def in_reset(self) -> bool:
        return self._in_reset

    @property
    def power_up_ms(self) -> float:
        """Master time of the last power-up (the end of a reset is one)."""
        return self._power_up_us / 1000

    @property
    def program_copy(self) -> tuple[float, int]:
        """When the program was last copied from the EEPROM (power-up, reset bit), in
        master time, and how many bytes the image there announced (0: none)."""
        return self._copied[0] / 1000, self._copied[1]

    @property
    def interrupt_request(self) -> bool:
        """The ISA interrupt line: an enabled source has an event pending."""
        return self._dpram.interrupt_request


def _fault(exc: Exception) -> str:
    """A program fault in words: the emulator's own message for what the 8051 cannot run
    (an undefined opcode), else what went wrong, named so that it can be reported."""
    if isinstance(exc, EmulatorError):
        return str(exc)
    return f"the emulation failed ({type(exc).__name__}: {exc}); please report it"
