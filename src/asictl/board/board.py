"""The emulated AS-i PC2 board: three I/O registers in front of a master with AS-i Control.

The host sees only what the ISA card shows (manual 7.2): a data register, INDEX and PAGE.
Behind them the DPRAM is the 8051's XDATA 0000h-03FFh: the board's storage *is* the
RAM of the bus the control program runs on, so flag bytes written by the host are the
program's flags, with no copying. Master time is virtual and moves only in ``advance``.

Speed: ``advance`` jumps over stretches in which nothing can change. An AS-i cycle with no
host access, no bus change and no due timer does nothing but the program cycle, and a
program cycle that left the whole machine state (internal RAM, SFRs, XDATA) as it found
it, calling no firmware block, will do so again until something external changes: such
cycles are skipped, and so are AS-i cycles with nothing left to do.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from asictl.board.asi import AsiBus, BusError
from asictl.board.commands import CommandsMixin
from asictl.board.control import AsiControl
from asictl.board.execution import ExecutionControl, Phase
from asictl.board.services import MasterFirmware
from asictl.image import ProgramImage
from asictl.mcs51.bus import Bus
from asictl.platform import pc2 as d
from asictl.platform.master import (
    CONTROL_FLAGS_NONVOLATILE,
    EEPROM_SIZE,
    NO_PROFILE,
    SLAVES,
    TICK_MS,
    ControlFlag,
)
from asictl.platform.pc2 import (
    ControlState,
    HiFlag,
    InterruptSource,
    StopReason,
    nibbles,
    pack_nibbles,
)
from asictl.runtime import layout
from asictl.runtime.runner import CycleTimeout, ProgramRunner

MASTER_NAME = b"AS-i PC2 Master / AS-i Control".ljust(32, b"\0")
MASTER_VERSION = b"asictl emulation".ljust(16, b"\0")
VERSION_ID = b"PC2C2.00"
#: One AS-i transaction (master call, pauses, slave answer) and the cycle's management call.
TRANSACTION_US = 150
TICK_US = TICK_MS * 1000
NONVOLATILE_FORMAT = "asictl-pc2-nonvolatile"
NONVOLATILE_VERSION = 1
#: The ODI is stored inverted (manual 7.3).
_INVERT = bytes(255 - b for b in range(256))
_ASI_CYCLE = int(InterruptSource.ASI_CYCLE)

# What a host write to a DPRAM byte means for the master (one code per address).
_PLAIN, _COMMAND, _MASTER_OWNED = 0, 1, 2
_KIND = bytearray(d.DPRAM_SIZE)
for _start, _size in (
    (d.INSTALLED_SOFTWARE, d.INSTALLED_SOFTWARE_SIZE),
    (d.IDI, d.IMAGE_SIZE),
    (d.EC_FLAGS, 1),
    (d.LAS, d.LIST_SIZE),
    (d.LDS, d.LIST_SIZE),
    (d.CDI, d.CONFIG_SIZE),
):
    _KIND[_start : _start + _size] = bytes([_MASTER_OWNED]) * _size
_KIND[d.COMMAND] = _COMMAND


class NonvolatileError(ValueError):
    """Saved board state that cannot be powered up from."""


class Pc2Board(CommandsMixin):
    """One PC2 board with its AS-i cable; see docs/master.md for what is modelled."""

    #: called after every AS-i cycle that ran (not after the ones skipped as idle)
    observer: Callable[[], None] | None = None
    _cycle_period_us: int | None = None

    def __init__(self, *, bus: AsiBus | None = None) -> None:
        self._boot(_factory_state(), bus if bus is not None else AsiBus(), now_us=0)

    @classmethod
    def from_nonvolatile(cls, data: dict[str, Any]) -> Pc2Board:
        """Power up with the state ``nonvolatile`` saved; ``NonvolatileError`` if malformed."""
        state, bus = _parse_nonvolatile(data)
        board = cls.__new__(cls)
        board._boot(state, bus, now_us=0)
        return board

    def nonvolatile(self) -> dict[str, Any]:
        """What survives power-off, JSON-able: EEPROM, settings, and the installation's slaves."""
        ec = self._ec
        return {
            "format": NONVOLATILE_FORMAT,
            "version": NONVOLATILE_VERSION,
            "eeprom": bytes(self._eeprom).rstrip(b"\xff").hex(),
            "control_flags": self._control.flags,
            "configuration_mode": ec.configuration_mode,
            "lps": list(_addresses(ec.lps)),
            "pcd": bytes(ec.pcd).hex(),
            "pp": pack_nibbles(ec.pp).hex(),
            "los": list(_addresses(ec.los)),
            "config_ok_delay": ec.config_ok_delay,
            "bus": self.bus.to_dict(),
        }

    # ------------------------------------------------------------------ power-up

    def _boot(self, state: dict[str, Any], bus: AsiBus, *, now_us: int) -> None:
        """Power-up: the DPRAM is written anew, everything volatile starts from scratch."""
        self.bus = bus
        self._now_us = now_us
        self._index = self._page = 0
        self._in_reset = False
        self._xdata = Bus()
        self._ram = self._xdata.ram
        self._eeprom = bytearray(state["eeprom"])
        self._ec = ExecutionControl(
            bus,
            configuration_mode=state["configuration_mode"],
            lps=state["lps"],
            pcd=state["pcd"],
            pp=state["pp"],
            los=state["los"],
            config_ok_delay=state["config_ok_delay"],
        )
        self._firmware = MasterFirmware(self._ec, self._eeprom, VERSION_ID)
        self._control = AsiControl(self._xdata, self._firmware, state["control_flags"])
        self._host_outputs = bytes(16)
        self._host_dirty = False
        self._command_pending = False
        self._lists_gen = self._settings_gen = -1
        self._status: tuple | None = None
        self._odi_written: bytes | None = None
        self._program_ready_us = 0
        self._timer_addresses: list[int] = []
        self._stirred = True
        self._quiet = False
        self._probe_wait = 0
        for slave in bus:
            slave.outputs = 0
        self._write_identity()
        self._ram[d.ODI : d.ODI + d.IMAGE_SIZE] = b"\xff" * d.IMAGE_SIZE
        self._ram[d.CONFIG_OK_DELAY] = self._ec.config_ok_delay
        self._load_program()
        self._write_settings()
        self._write_lists()
        self._write_control_flags()
        self._write_status()
        self._next_cycle_us = now_us + self._period()
        self._next_tick_us = now_us + TICK_US

    def _load_program(self) -> bool:
        loaded = self._control.load(self._eeprom)
        runner = self._control.runner
        self._timer_addresses = sorted(runner.pmap.timers.values()) if runner else []
        self._quiet = False
        self._stirred = True
        return loaded

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
            self._host_write(self._page << 8 | self._index, value)
            self._step_index()
        elif offset == d.PORT_INDEX:
            self._index = value
        elif offset == d.PORT_PAGE:
            self._page = value & d.PAGE_MASK
            if value & d.PAGE_RESET_BIT and not self._in_reset:
                self._hold_reset()
            elif not value & d.PAGE_RESET_BIT and self._in_reset:
                self._boot(self._saved, self.bus, now_us=self._now_us)
        else:
            raise ValueError(f"the PC2 board decodes I/O offsets 0..2, not {offset}")

    def _step_index(self) -> None:
        """INDEX counts up; after byte 255 of a page both INDEX and PAGE start again at 0."""
        if self._index == 0xFF:
            self._index = self._page = 0
        else:
            self._index += 1

    def _host_write(self, address: int, value: int) -> None:
        self._ram[address] = value
        self._stirred = True
        self._host_dirty = True
        kind = _KIND[address]
        if kind == _COMMAND:
            self._command_pending = value not in (d.ACK, d.NAK)
        elif kind == _MASTER_OWNED:
            self._lists_gen = -1  # the master writes these cyclically: the host's byte goes

    def _hold_reset(self) -> None:
        """PAGE bit 4: the board stops; the slaves, no longer called, switch off."""
        self._saved, _ = _parse_nonvolatile(self.nonvolatile())
        self._in_reset = True
        for slave in self.bus:
            slave.outputs = 0

    # ------------------------------------------------------------------ time

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
            tick, cycle = self._next_tick_us, self._next_cycle_us
            now = min(tick, cycle)
            if now > end:
                break
            self._now_us = now
            if now == tick:
                self._tick()
                self._next_tick_us = tick + TICK_US
            if now == cycle:
                self._cycle()
                if self.observer is not None:
                    self.observer()
                period = self._period()
                skip = self._idle_cycles(now, period, end) if self._idle() else 0
                if skip:
                    self._ec.count_idle_cycles(skip)
                self._next_cycle_us = now + (skip + 1) * period
        self._now_us = end

    def _period(self) -> int:
        """About 150 us per active slave plus one call: 300 us (1 slave) to 4.8 ms (31)."""
        if self._cycle_period_us is not None:
            return self._cycle_period_us
        return TRANSACTION_US * (max(self._ec.active_count, 1) + 1)

    @property
    def cycle_period_us(self) -> int | None:
        """A fixed AS-i cycle time in microseconds instead of the slave-count rule (None)."""
        return self._cycle_period_us

    @cycle_period_us.setter
    def cycle_period_us(self, value: int | None) -> None:
        if value is not None and (not isinstance(value, int) or value <= 0):
            raise ValueError(f"an AS-i cycle lasts a positive number of microseconds, not {value}")
        self._cycle_period_us = value

    def _idle(self) -> bool:
        """Would the next AS-i cycle change nothing? Then so would all until the next tick."""
        return not (
            self._host_dirty
            or self._command_pending
            or not self._ec.settled
            or not self._ec.in_step(self._outputs())
            or (self._control.running and (not self._quiet or self._stirred))
        )

    def _idle_cycles(self, now: int, period: int, end: int) -> int:
        """How many AS-i cycles after ``now`` can be skipped, and skip the ticks among them.

        Cycles before the next tick can always go; when the ticks themselves change
        nothing (watchdog off, no program timer running) everything up to ``end`` can.
        """
        ticks_idle = not self._ram[d.WATCHDOG_ENABLE] and not (
            self._control.running and self._timers_running()
        )
        if not ticks_idle:
            return max(0, min((self._next_tick_us - now - 1) // period, (end - now) // period))
        skip = max(0, (end - now) // period)
        last = now + skip * period
        if self._next_tick_us <= last:
            self._next_tick_us += ((last - self._next_tick_us) // TICK_US + 1) * TICK_US
        return skip

    def _tick(self) -> None:
        """The 10 ms clock: watchdog, program timers."""
        ram = self._ram
        if ram[d.WATCHDOG_ENABLE]:
            count = ram[d.WATCHDOG_COUNTER]
            if count:
                count -= 1
                ram[d.WATCHDOG_COUNTER] = count
                self._stirred = True
            if not count:  # time-out: offline until the host clears the offline flag
                ram[d.WATCHDOG_ENABLE] = 0
                ram[d.HI_FLAGS] |= HiFlag.OFFLINE
                self._read_host_flags()
                self._write_status()  # the W/w and O/o letters change with it
        if self._control.running and self._timers_running():
            self._control.runner.tick()
            self._stirred = True

    def _timers_running(self) -> bool:
        return any(self._ram[a] or self._ram[a + 1] for a in self._timer_addresses)

    # ------------------------------------------------------------------ the AS-i cycle

    def _cycle(self) -> None:
        """One AS-i cycle: host images and commands, execution control, data, program."""
        ec = self._ec
        if self._host_dirty:
            self._read_host_images()
        if self._command_pending:
            self._command_pending = False
            code = self._ram[d.COMMAND]
            ok = self._run_command(code)
            self._ram[d.COMMAND] = d.ACK if ok else d.NAK
        ec.step(self._now_us)
        if ec.generation != self._lists_gen:
            self._write_lists()
        if ec.settings_generation != self._settings_gen:
            self._write_settings()
        self._update_control()
        if ec.exchange(self._outputs()):
            self._put(d.IDI, ec.idi)
            self._interrupt(InterruptSource.IDI_CHANGE)
        if self._control.running and self._now_us >= self._program_ready_us:
            self._program_cycle()
        if self._ram[d.INTERRUPT_ENABLE] & _ASI_CYCLE and ec.phase is Phase.NORMAL:
            self._interrupt(InterruptSource.ASI_CYCLE)

    def _outputs(self) -> bytes | bytearray:
        runner = self._control.runner
        return runner.outputs if self._control.running else self._host_outputs

    def _read_host_images(self) -> None:
        """The images the master reads cyclically: ODI, PI, hi-flags, and its settings."""
        self._host_dirty = False
        ram, ec = self._ram, self._ec
        odi = bytes(ram[d.ODI : d.ODI + d.IMAGE_SIZE])
        if self._control.running:
            if odi != self._odi_written:
                self._odi_written = None  # the program's outputs overwrite the host's
        else:
            self._host_outputs = odi.translate(_INVERT)
        pi = nibbles(ram[d.PI : d.PI + d.IMAGE_SIZE])
        for a in range(SLAVES):
            if pi[a] != ec.pi[a]:
                ec.write_parameter(a, pi[a])
        self._read_host_flags()
        ec.config_ok_delay = ram[d.CONFIG_OK_DELAY]
        self._write_status()

    def _read_host_flags(self) -> None:
        hi = self._ram[d.HI_FLAGS]
        self._ec.set_host_flags(
            data_exchange_active=not hi & HiFlag.DATA_EXCHANGE_OFF,
            offline=bool(hi & HiFlag.OFFLINE),
            auto_address_enable=not hi & HiFlag.AUTO_ADDRESS_OFF,
        )

    def _update_control(self) -> None:
        control, ec = self._control, self._ec
        blocker = control.blocker(normal=ec.phase is Phase.NORMAL, config_ok=ec.config_ok)
        if control.running:
            if blocker is StopReason.NONE:
                return
            control.stop(blocker)
            self._safe_outputs()
        elif blocker is StopReason.NONE:
            control.start()
            self._program_ready_us = self._now_us
            self._stirred = True
        else:
            control.reason = blocker
        self._write_status()

    def _program_cycle(self) -> None:
        control = self._control
        if self._quiet and not self._stirred:
            return
        self._stirred = False
        runner = control.runner
        probe = self._probe_wait == 0
        calls = self._firmware.calls
        before = self._snapshot(runner) if probe else b""
        try:
            runner.cycle(self._ec.idi)
        except CycleTimeout as exc:
            control.stop(StopReason.CYCLE_TIMEOUT, str(exc))
            self._safe_outputs()
            self._write_status()
            return
        duration = control.record_cycle(runner.last_cycles)
        self._program_ready_us = self._now_us + math.ceil(duration)
        if probe:
            self._quiet = calls == self._firmware.calls and before == self._snapshot(runner)
            self._probe_wait = 0 if self._quiet else 16
        else:
            self._probe_wait -= 1
            self._quiet = False
        odi = bytes(runner.outputs).translate(_INVERT)
        if odi != self._odi_written:
            self._odi_written = odi
            self._put(d.ODI, odi)
        if self._ec.settings_generation != self._settings_gen:
            self._write_settings()  # DataEx/AutoAddr/SetPP: before the host's images are read

    @staticmethod
    def _snapshot(runner: ProgramRunner) -> bytes:
        cpu = runner.cpu
        return bytes(cpu.iram) + bytes(cpu.sfr) + bytes(cpu.xdata.ram[: layout.DATA_LIMIT])

    def _safe_outputs(self) -> None:
        """Program stopped: outputs 0 until the host writes the ODI (stored inverted)."""
        self._host_outputs = bytes(16)
        self._odi_written = None
        self._put(d.ODI, b"\xff" * d.IMAGE_SIZE)

    # ------------------------------------------------------------------ DPRAM images

    def _put(self, address: int, data: bytes | bytearray) -> None:
        """Write master data to the DPRAM; a change is news for the running program."""
        end = address + len(data)
        if self._ram[address:end] != data:
            self._ram[address:end] = data
            self._stirred = True

    def _write_identity(self) -> None:
        self._put(d.MASTER_NAME, MASTER_NAME + MASTER_VERSION)
        self._put(d.VERSION_ID, VERSION_ID)

    def _write_lists(self) -> None:
        """What the master writes cyclically: ec-flags, LAS, LDS, CDI."""
        ec, ram = self._ec, self._ram
        self._lists_gen = ec.generation
        if (ram[d.EC_FLAGS] ^ ec.ec_flags) & d.EcFlag.CONFIG_OK:
            self._interrupt(InterruptSource.CONFIG_OK_CHANGE)
        self._put(d.EC_FLAGS, bytes([ec.ec_flags]))
        self._put(d.IDI, ec.idi)
        self._put(d.LAS, ec.las.to_bytes(4, "little"))
        self._put(d.LDS, ec.lds.to_bytes(4, "little"))
        self._put(d.CDI, ec.cdi)
        self._status = None
        self._write_status()

    def _write_settings(self) -> None:
        """The images the master rewrites when it changes them: LPS, PCD, PP, PI, LOS, hi."""
        ec = self._ec
        self._settings_gen = ec.settings_generation
        self._put(d.LPS, ec.lps.to_bytes(4, "little"))
        self._put(d.PCD, ec.pcd)
        self._put(d.PP, pack_nibbles(ec.pp))
        self._put(d.PI, pack_nibbles(ec.pi))
        self._put(d.LOS, ec.los.to_bytes(4, "little"))
        hi = (
            (0 if ec.data_exchange_active else HiFlag.DATA_EXCHANGE_OFF)
            | (HiFlag.OFFLINE if ec.offline else 0)
            | (0 if ec.auto_address_enable else HiFlag.AUTO_ADDRESS_OFF)
        )
        self._put(d.HI_FLAGS, bytes([hi]))
        self._status = None
        self._write_status()

    def _write_status(self) -> None:
        """The installed-software letters and this board's status bytes 305h-307h."""
        control, ec, ram = self._control, self._ec, self._ram
        status = (
            control.running, ec.data_exchange_active, ec.offline, ec.auto_address_enable,
            bool(ram[d.WATCHDOG_ENABLE]), control.program_status, control.reason, control.state,
        )
        if status == self._status:
            return
        self._status = status
        letters = (
            "C" if control.running else "c",
            "BFEDC..",
            "D" if ec.data_exchange_active else "d",
            "O" if ec.offline else "o",
            "A" if ec.auto_address_enable else "a",
            "...",
            "W" if ram[d.WATCHDOG_ENABLE] else "w",
            ".",
        )
        self._put(d.INSTALLED_SOFTWARE, "".join(letters).encode("ascii"))
        self._put(d.PROGRAM_STATUS, bytes([control.program_status, control.reason, control.state]))

    def _write_control_flags(self) -> None:
        self._ram[d.CONTROL_FLAGS] = self._control.flags_byte()

    def _write_cycle_times(self) -> None:
        for address, us in (
            (d.CYCLE_TIME_PREVIOUS, self._control.previous_us),
            (d.CYCLE_TIME_MAXIMUM, self._control.maximum_us),
        ):
            units = min(0xFFFF, math.ceil(us / d.CYCLE_TIME_UNIT_US))
            self._put(address, units.to_bytes(2, "little"))

    def _interrupt(self, source: InterruptSource) -> None:
        ram = self._ram
        if ram[d.INTERRUPT_ENABLE] & source and not ram[d.INTERRUPT_EVENT] & source:
            ram[d.INTERRUPT_EVENT] |= source
            self._stirred = True

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
        return bytes(self._ram[: d.DPRAM_SIZE])

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
    def stop_reason(self) -> StopReason:
        return self._control.reason

    @property
    def stop_message(self) -> str:
        """Why the control program is not running, in words (the time-out's own message)."""
        return self._control.message

    @property
    def control_flags(self) -> ControlFlag:
        return ControlFlag(self._control.flags_byte())

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
    def interrupt_request(self) -> bool:
        """The ISA interrupt line: an enabled source has an event pending."""
        return bool(self._ram[d.INTERRUPT_ENABLE] & self._ram[d.INTERRUPT_EVENT])


# ---------------------------------------------------------------------- non-volatile state


def _addresses(mask: int) -> list[int]:
    return [a for a in range(SLAVES) if mask >> a & 1]


def _factory_state() -> dict[str, Any]:
    """A new board: empty EEPROM, configuration mode, nothing projected."""
    return {
        "eeprom": b"\xff" * EEPROM_SIZE,
        "control_flags": 0,
        "configuration_mode": True,
        "lps": 0,
        "pcd": bytes([NO_PROFILE]) * SLAVES,
        "pp": bytes([0xF]) * SLAVES,
        "los": 0,
        "config_ok_delay": 2,
    }


def _parse_nonvolatile(data: Any) -> tuple[dict[str, Any], AsiBus]:
    if not isinstance(data, dict):
        raise NonvolatileError(f"board state must be an object, not {type(data).__name__}")
    if data.get("format") != NONVOLATILE_FORMAT:
        raise NonvolatileError(
            f"not a saved PC2 board state (format {data.get('format')!r}, "
            f"expected {NONVOLATILE_FORMAT!r})"
        )
    if data.get("version") != NONVOLATILE_VERSION:
        raise NonvolatileError(
            f"saved board state version {data.get('version')!r}; "
            f"this asictl reads version {NONVOLATILE_VERSION}"
        )
    state = _factory_state()
    eeprom = _hex(data, "eeprom", max_size=EEPROM_SIZE)
    state["eeprom"] = eeprom + b"\xff" * (EEPROM_SIZE - len(eeprom))
    state["control_flags"] = _byte(data, "control_flags") & CONTROL_FLAGS_NONVOLATILE
    mode = data.get("configuration_mode")
    if not isinstance(mode, bool):
        raise NonvolatileError(f"'configuration_mode' must be true or false, not {mode!r}")
    state["configuration_mode"] = mode
    state["lps"] = _slave_list(data, "lps", first=1)
    state["los"] = _slave_list(data, "los", first=0)
    state["pcd"] = _hex(data, "pcd", size=SLAVES)
    state["pp"] = nibbles(_hex(data, "pp", size=d.IMAGE_SIZE))
    state["config_ok_delay"] = _byte(data, "config_ok_delay")
    try:
        bus = AsiBus.from_dict(data.get("bus", {"slaves": []}))
    except BusError as exc:
        raise NonvolatileError(f"saved board state: bus: {exc}") from None
    return state, bus


def _byte(data: dict[str, Any], key: str) -> int:
    value = data.get(key)
    if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= 0xFF:
        raise NonvolatileError(f"saved board state: '{key}' must be a byte 0..255, not {value!r}")
    return value


def _hex(data: dict[str, Any], key: str, *, size: int = -1, max_size: int = -1) -> bytes:
    text = data.get(key)
    try:
        raw = bytes.fromhex(text) if isinstance(text, str) else None
    except ValueError:
        raw = None
    if raw is None or (size >= 0 and len(raw) != size) or (0 <= max_size < len(raw)):
        wanted = f"{size} bytes" if size >= 0 else f"at most {max_size} bytes"
        raise NonvolatileError(f"saved board state: '{key}' must be hex text of {wanted}")
    return raw


def _slave_list(data: dict[str, Any], key: str, *, first: int) -> int:
    value = data.get(key)
    if not isinstance(value, list) or not all(
        isinstance(a, int) and not isinstance(a, bool) and first <= a < SLAVES for a in value
    ):
        raise NonvolatileError(
            f"saved board state: '{key}' must be a list of slave addresses {first}..31"
        )
    return sum(1 << a for a in set(value))
