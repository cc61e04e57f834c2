"""``asictl status``: what ASI_MON's screens showed, as text or JSON (docs/commissioning.md).

Everything comes from the DPRAM after Get Status (51) has refreshed the control flags
and cycle times, plus the image header in the EEPROM (Upload, 53) for the program's
identity: per slave its input and output data, projected and actual configuration and
parameters, and the lists it is in; the hi-flags, the flag bytes F0..F127 and the cycle
times. What the DPRAM does not hold (the LCS and error counters without clearing them,
the program's timers and counters) an emulated board adds from its ``view`` action; on
real hardware they are ``None`` (``asictl diag`` reads and clears the diagnostics).
Configuration errors are shown by their cause: a projected slave that is not detected is
missing, a detected one that is not projected is unexpected (slave 0, a new slave, is
neither), and a detected slave whose configuration (CDI) differs from the projected one
(PCD) is wrong.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from enum import IntEnum
from typing import Any, assert_never

from asictl.errors import ExitCode, UserError
from asictl.host.cycle_units import cycle_text, other_reading, raw_value
from asictl.host.force_list import ForcedValue, entries_from_json, forced_values
from asictl.host.raw_image import foreign_eeprom
from asictl.host.transfer import Pc2Transport, Transport, upload, upload_head
from asictl.host.transports.driver import Pc2Driver
from asictl.host.transports.jobs import JobError, JobStatus
from asictl.il import ast
from asictl.image.eeprom import MAGIC, ProgramImage
from asictl.observe.operands import Operand, image_symbols, parse_operand
from asictl.observe.symbols import SymbolTable
from asictl.platform.display import Display, derived, led_text
from asictl.platform.display import leds as derived_leds
from asictl.platform.master import SLAVES, ControlFlag
from asictl.platform.pc2 import (
    CDI,
    CONFIG_SIZE,
    CONTROL_FLAGS,
    CONTROL_STATE,
    CYCLE_TIME_MAXIMUM,
    CYCLE_TIME_PREVIOUS,
    CYCLE_TIME_UNIT_US,
    EC_FLAGS,
    FLAGS,
    FLAGS_SIZE,
    HI_FLAGS,
    IDI,
    IMAGE_SIZE,
    INSTALLED_SOFTWARE,
    INSTALLED_SOFTWARE_SIZE,
    LAS,
    LDS,
    LIST_SIZE,
    LOS,
    LPS,
    MASTER_NAME,
    MASTER_NAME_SIZE,
    ODI,
    PCD,
    PI,
    PP,
    PROGRAM_STATUS,
    STOP_ADDRESS,
    STOP_REASON,
    STOPS_AT_AN_ADDRESS,
    VERSION_ID,
    VERSION_ID_SIZE,
    Command,
    ControlState,
    EcFlag,
    HiFlag,
    ProgramStatus,
    StopReason,
    nibbles,
)
from asictl.readers.units import format_duration

#: The version of ``status --json``'s object (its ``schema`` key): raised when a key
#: changes its meaning or goes away, not when one is added.
STATUS_SCHEMA = 1
#: The slave lists a slave can be in, in ASI_MON's order.
LISTS = ("LPS", "LDS", "LAS", "LCS", "LOS")
#: What an emulated board's ``view`` action adds (None: not available on this master).
View = dict[str, Any]


@dataclass(frozen=True)
class ProgramInfo:
    """The image in the EEPROM: what a reset would load."""

    present: bool
    valid: bool
    identity: str | None = None
    size: int = 0
    code_size: int = 0
    source_included: bool = False
    problem: str | None = None


@dataclass(frozen=True)
class WrongSlave:
    slave: int
    #: the slave's PCD/CDI byte (ID code << 4 | I/O code)
    projected: int
    detected: int


@dataclass(frozen=True)
class SlaveData:
    """One slave as ASI_MON showed it; profiles are PC2 bytes (ID code << 4 | I/O code)."""

    #: input data (IDI) and output data as the slave receives it (the ODI, not inverted)
    inputs: int
    outputs: int
    pcd: int
    cdi: int
    pp: int
    pi: int
    #: the lists the slave is in, of LISTS
    lists: list[str]
    #: its error counter (failed telegrams since the last read), where the master shows it
    errors: int | None = None


@dataclass(frozen=True)
class Timer:
    number: int
    remaining_ms: int
    running: bool


@dataclass(frozen=True)
class Counter:
    number: int
    value: int


@dataclass(frozen=True)
class MasterStatus:
    port: str
    master_name: str
    version_id: str
    installed_software: str
    ec_flags: int
    phase: str
    mode: str
    config_ok: bool
    power_fail: bool
    lps: list[int]
    lds: list[int]
    las: list[int]
    missing: list[int]
    unexpected: list[int]
    wrong_profile: list[WrongSlave]
    #: the gateway's display (gateway manual, chapter 8): its panel's own where the board
    #: is served by the emulated gateway (``panel`` "gateway"), else what it would show
    #: for this state (``panel`` "derived")
    display: Display
    control_flags: int
    start_flag: bool
    ignore_config_errors: bool
    wait_for_set_button: bool
    map_counters: bool
    control_active: bool
    control_state: str
    stop_reason: str | None
    program_status: str
    cycle_time_ms: float
    max_cycle_time_ms: float
    program: ProgramInfo
    #: per slave, keyed by its decimal address, for every slave in any list
    slaves: dict[str, SlaveData] = field(default_factory=dict)
    los: list[int] = field(default_factory=list)
    #: the list of corrupted slaves, None where it cannot be read without clearing it
    lcs: list[int] | None = None
    hi_flags: int = 0
    #: the control program's flag bytes F0..F127
    flags: list[int] = field(default_factory=lambda: [0] * FLAGS_SIZE)
    #: the program's timers and counters, None where the master does not show them
    timers: list[Timer] | None = None
    counters: list[Counter] | None = None
    #: after a cycle time-out or a program fault: the IL line of the endless loop or of the
    #: fault (from the image's line map)
    stop_line: str | None = None
    #: the gateway's seven LEDs by name (platform/display.LEDS); None for a PC2 board
    leds: dict[str, bool] | None = None
    #: where display and LEDs come from: "gateway" (the served gateway's panel) or
    #: "derived" (worked out from the master's flags and lists)
    panel: str = "derived"
    #: the gateway's key lock (register 1007), where it is known
    keys_locked: bool | None = None
    #: the force list (host/forcing.py), None where the master has none (real hardware)
    forced: list[ForcedValue] | None = None
    #: the symbol table the program on the master carries: name -> operand
    symbols: dict[str, str] = field(default_factory=dict)
    #: whether the master reports its program cycle times (a gateway does not: 0 then)
    cycle_times_known: bool = True
    #: a live board a debugger holds still: ``halted at breakpoint line 6 by asictl dap
    #: (pid 7)``; None while the master runs
    held: str | None = None

    def to_json(self) -> dict[str, Any]:
        """The object ``status --json`` prints (docs/commissioning.md has every key);
        ``schema`` counts its incompatible changes."""
        data = {"schema": STATUS_SCHEMA, **asdict(self)}
        data["display"] = self.display.to_json()
        return data


def _slaves(bits: bytes) -> list[int]:
    return [n for n in range(SLAVES) if bits[n // 8] >> n % 8 & 1]


def _text(raw: bytes) -> str:
    """A DPRAM string: NUL-padded parts (the master's name, then its version) joined."""
    parts = (part.decode("latin-1").strip() for part in raw.split(b"\0"))
    return " ".join(part for part in parts if part)


def _name(enum: type[IntEnum], value: int) -> str:
    try:
        return str(enum(value).name).lower().replace("_", " ")
    except ValueError:
        return f"unknown ({value:02X}h)"


def _phase(ec: int) -> str:
    if ec & EcFlag.OFFLINE_READY:
        return "offline"
    if ec & EcFlag.NORMAL_OPERATION_ACTIVE:
        return "normal operation"
    return "start-up"


def _cycle_ms(raw: bytes) -> float:
    return int.from_bytes(raw, "little") * CYCLE_TIME_UNIT_US / 1000


@dataclass(frozen=True)
class StoredProgram:
    """The EEPROM's program as read once: its description, and the image itself (None
    when there is none or it does not read) for what only the image knows: the IL line
    of an address, the source. A monitor keeps it between refreshes."""

    info: ProgramInfo
    image: ProgramImage | None = None

    @functools.cached_property
    def symbols(self) -> SymbolTable:
        """The image's symbol table, parsed once: a monitor reads the status every
        refresh with the same program."""
        return image_symbols(self.image)


def program_info(transport: Transport) -> ProgramInfo:
    return read_program(transport).info


def read_program(transport: Transport) -> StoredProgram:
    """Upload (53) the image in the EEPROM and describe it."""
    head = upload_head(transport)  # read once: the check here, and the upload's start
    if head[: len(MAGIC)] != MAGIC:
        return StoredProgram(ProgramInfo(
            present=False, valid=False, problem=foreign_eeprom(transport, head)
        ))
    try:
        image = upload(transport, head)
    except JobError as exc:
        if exc.status is not JobStatus.EEPROM_ERROR:
            raise
        return StoredProgram(ProgramInfo(present=True, valid=False, problem=str(exc)))
    return StoredProgram(ProgramInfo(
        present=True, valid=True, identity=image.identity_hex, size=len(image.to_bytes()),
        code_size=len(image.code), source_included=bool(image.source),
    ), image)


def stop_line(driver: Pc2Driver, image: ProgramImage | None) -> str | None:
    """The IL line where the program stopped (``loop.asi:12``): the loop a cycle time-out
    cut off, the fault: the master's stop address through the image's line map; None when
    the image has none."""
    if image is None:
        return None
    address = int.from_bytes(driver.read(STOP_ADDRESS, 2), "little")
    line = image.line_map.line_at(address)
    return None if line is None else str(line)


def state_fields(ec: int, flags: int) -> dict[str, Any]:
    """The fields ``MasterStatus`` derives from the ec-flags and the AS-i Control flags."""
    return {
        "ec_flags": ec,
        "phase": _phase(ec),
        "mode": "configuration" if ec & EcFlag.CONFIGURATION_ACTIVE else "protected",
        "config_ok": bool(ec & EcFlag.CONFIG_OK),
        "power_fail": bool(ec & EcFlag.APF),
        "control_flags": flags,
        "start_flag": bool(flags & ControlFlag.START),
        "ignore_config_errors": bool(flags & ControlFlag.IGNORE_CONFIG_ERRORS),
        "wait_for_set_button": bool(flags & ControlFlag.WAIT_FOR_SET_BUTTON),
        "map_counters": bool(flags & ControlFlag.MAP_COUNTERS),
        "control_active": bool(flags & ControlFlag.CONTROL_ACTIVE),
    }


def slave_fields(
    lps: list[int], lds: list[int], las: list[int], pcd: bytes, cdi: bytes, *, ec: int
) -> dict[str, Any]:
    """The slave lists, the configuration errors by their cause (PCD/CDI in PC2 layout)
    and the display code they make."""
    phase = {"normal operation": "normal", "offline": "offline"}.get(_phase(ec), "detection")
    return {
        "display": derived(
            phase, bool(ec & EcFlag.CONFIGURATION_ACTIVE), sum(1 << n for n in lps),
            sum(1 << n for n in lds), pcd, cdi,
        ),
        "lps": lps, "lds": lds, "las": las,
        "missing": [n for n in lps if n not in lds],
        "unexpected": [n for n in lds if n not in lps and n != 0],
        "wrong_profile": [
            WrongSlave(n, pcd[n], cdi[n]) for n in lps if n in lds and pcd[n] != cdi[n]
        ],
    }


def slave_data(
    lists: dict[str, list[int]], *, inputs: bytes, outputs: bytes, pcd: bytes, cdi: bytes,
    pp: bytes, pi: bytes, errors: bytes | None = None,
) -> dict[str, SlaveData]:
    """Per-slave rows for every slave in any list; the images one value per slave."""
    members = sorted({n for addresses in lists.values() for n in addresses})
    return {
        str(n): SlaveData(
            inputs=inputs[n], outputs=outputs[n], pcd=pcd[n], cdi=cdi[n], pp=pp[n], pi=pi[n],
            lists=[name for name in LISTS if n in lists.get(name, ())],
            errors=None if errors is None else errors[n],
        )
        for n in members
    }


def view_fields(view: View | None) -> dict[str, Any]:
    """The ``MasterStatus`` fields an emulated board's view gives; a board the emulated
    gateway serves adds its front panel (``panel``: display, LEDs, key lock)."""
    if view is None:
        return {}
    fields: dict[str, Any] = {
        "lcs": list(view["lcs"]),
        "timers": [Timer(t["number"], t["remaining_ms"], t["running"]) for t in view["timers"]],
        "counters": [Counter(c["number"], c["value"]) for c in view["counters"]],
        "held": view.get("held"),
    }
    panel = view.get("panel")
    if isinstance(panel, dict):
        fields.update(panel_fields(panel))
    return fields


def panel_fields(panel: dict[str, Any]) -> dict[str, Any]:
    """The ``MasterStatus`` fields the emulated gateway's front panel gives (its ``view``):
    the display and LEDs as the panel shows them, its key lock."""
    return {
        "display": Display.from_json(panel["display"]), "leds": dict(panel["leds"]),
        "panel": "gateway", "keys_locked": bool(panel["keys_locked"]),
    }


def gateway_panel(ec: int, software: str) -> dict[str, Any]:
    """What a gateway's LEDs show, from its ec-flags and its installed-software letters
    (byte 15: T keys free, t locked), for a gateway reached over Modbus: that the
    client talks to it is the Modbus communication that lights ser active."""
    return {
        "leds": derived_leds(ec, ser_active=True),
        "keys_locked": software[15:16] == "t" if len(software) >= 16 else None,
    }


def read_status(
    driver: Pc2Driver, port: str, view: Callable[[], View | None] | None = None, *,
    program: StoredProgram | None = None,
) -> MasterStatus:
    """Refresh (51), then read the DPRAM and the EEPROM's image (unless ``program`` is
    given: a monitor reads the image only when it may have changed, and keeps it, so
    that a cycle time-out is still named by its IL line)."""
    driver.command(Command.GET_STATUS)
    ec = driver.read_byte(EC_FLAGS)
    lps, lds, las = (_slaves(driver.read(a, LIST_SIZE)) for a in (LPS, LDS, LAS))
    pcd, cdi = driver.read(PCD, CONFIG_SIZE), driver.read(CDI, CONFIG_SIZE)
    flags = driver.read_byte(CONTROL_FLAGS)
    state, reason = driver.read_byte(CONTROL_STATE), driver.read_byte(STOP_REASON)
    los = _slaves(driver.read(LOS, LIST_SIZE))
    extra = view() if view is not None else None
    lcs = list(extra["lcs"]) if extra is not None else []
    odi = driver.read(ODI, IMAGE_SIZE)
    slaves = slave_data(
        {"LPS": lps, "LDS": lds, "LAS": las, "LCS": lcs, "LOS": los},
        inputs=nibbles(driver.read(IDI, IMAGE_SIZE)),
        outputs=nibbles(bytes(0xFF - b for b in odi)),
        pcd=pcd, cdi=cdi,
        pp=nibbles(driver.read(PP, IMAGE_SIZE)), pi=nibbles(driver.read(PI, IMAGE_SIZE)),
        errors=None if extra is None else bytes(extra["error_counters"]),
    )
    if program is None:
        program = read_program(Pc2Transport(driver))
    symbols = program.symbols
    return MasterStatus(
        port=port,
        master_name=_text(driver.read(MASTER_NAME, MASTER_NAME_SIZE)),
        version_id=_text(driver.read(VERSION_ID, VERSION_ID_SIZE)),
        installed_software=_text(driver.read(INSTALLED_SOFTWARE, INSTALLED_SOFTWARE_SIZE)),
        **state_fields(ec, flags),
        **{**slave_fields(lps, lds, las, pcd, cdi, ec=ec), **view_fields(extra)},
        control_state=_name(ControlState, state),
        stop_reason=None if reason == StopReason.NONE else _name(StopReason, reason),
        program_status=_name(ProgramStatus, driver.read_byte(PROGRAM_STATUS)),
        cycle_time_ms=_cycle_ms(driver.read(CYCLE_TIME_PREVIOUS, 2)),
        max_cycle_time_ms=_cycle_ms(driver.read(CYCLE_TIME_MAXIMUM, 2)),
        program=program.info,
        stop_line=stop_line(driver, program.image) if reason in STOPS_AT_AN_ADDRESS else None,
        slaves=slaves,
        los=los,
        hi_flags=driver.read_byte(HI_FLAGS),
        flags=list(driver.read(FLAGS, FLAGS_SIZE)),
        forced=None if extra is None else forced_values(
            entries_from_json(extra.get("forced", [])), symbols),
        symbols={name: text for name, text in symbols.entries.values()},
    )


def derived_control_state(
    program: bool, flags: int, ec: int
) -> tuple[ControlState, StopReason | None]:
    """The control state and stop reason as the PC2 reports them (307h, 306h), worked out
    from what a gateway shows (the flags, the ec-flags, whether the EEPROM holds an
    image), in the order the master checks them (board/control.py). None: stopped with
    the start flag set in normal operation and a good configuration, which is a cycle
    time-out, a program fault or a wait for the set button, which the gateway does not
    tell apart."""
    if flags & ControlFlag.CONTROL_ACTIVE:
        return ControlState.RUNNING, StopReason.NONE
    if not program:
        return ControlState.IDLE, StopReason.NO_PROGRAM
    if not flags & ControlFlag.START:
        return ControlState.IDLE, StopReason.NOT_STARTED
    if not ec & EcFlag.NORMAL_OPERATION_ACTIVE:
        return ControlState.WAITING, StopReason.NOT_NORMAL_OPERATION
    if not ec & EcFlag.CONFIG_OK and not flags & ControlFlag.IGNORE_CONFIG_ERRORS:
        return ControlState.WAITING, StopReason.CONFIG_ERROR
    return ControlState.HALTED, None


def state_summary(state: ControlState, reason: StopReason | None) -> str:
    """``control program STATE (REASON)``, the one line a command ends with."""
    text = f"control program {_name(ControlState, state)}"
    if reason is None:
        return text + " (a cycle time-out, a program fault or waiting for the set button)"
    if reason is StopReason.NONE:
        return text
    return f"{text} ({_name(StopReason, reason)})"


def control_summary(driver: Pc2Driver) -> str:
    """One line on the control program after a command: what it does, and why not."""
    state = _name(ControlState, driver.read_byte(CONTROL_STATE))
    reason = driver.read_byte(STOP_REASON)
    if reason == StopReason.NONE:
        return f"control program {state}"
    where = None
    if reason in STOPS_AT_AN_ADDRESS:
        where = stop_line(driver, read_program(Pc2Transport(driver)).image)
    return f"control program {state} ({_stopped(_name(StopReason, reason), where)})"


def _stopped(reason: str, where: str | None) -> str:
    """``loop.asi:12: cycle time-out``, or the reason alone."""
    return f"{where}: {reason}" if where else reason


def stop_text(status: MasterStatus) -> str | None:
    """Why the program does not run, with the IL line where it stopped if known:
    ``loop.asi:9: cycle timeout``; None while it runs."""
    return None if status.stop_reason is None else _stopped(status.stop_reason, status.stop_line)


def _slave_row(label: str, slaves: list[int]) -> str:
    return f"{label:<5}" + "".join("X" if n in slaves else "." for n in range(SLAVES))


def _profile(byte: int) -> str:
    return f"IO {byte & 0xF:X}h ID {byte >> 4:X}h"


def hi_flag_text(hi: int) -> str:
    """The host interface flags in words (bits 0 and 2 are inverted on the wire)."""
    return ", ".join((
        "data exchange " + ("off" if hi & HiFlag.DATA_EXCHANGE_OFF else "on"),
        "offline" if hi & HiFlag.OFFLINE else "online",
        "auto address " + ("off" if hi & HiFlag.AUTO_ADDRESS_OFF else "on"),
    ))


def profile_text(byte: int) -> str:
    """A PC2 profile byte as I/O code then ID code, as [SETUP] writes them: ``8/0``."""
    return f"{byte & 0xF:X}/{byte >> 4:X}"


def slave_rows(slaves: dict[str, SlaveData]) -> list[str]:
    rows = ["slave  in    out   PCD  CDI  PP PI  lists               errors"]
    for key, v in sorted(slaves.items(), key=lambda item: int(item[0])):
        rows.append(
            f"{int(key):>5}  {v.inputs:04b}  {v.outputs:04b}  {profile_text(v.pcd):<4} "
            f"{profile_text(v.cdi):<4} {v.pp:X}  {v.pi:X}   {' '.join(v.lists):<19} "
            + ("-" if v.errors is None else str(v.errors))
        )
    return rows


def flag_rows(flags: list[int]) -> list[str]:
    """F0..F127 as a hex dump, 16 bytes a line."""
    return [
        f"F{start:<4}" + " ".join(f"{b:02X}" for b in flags[start : start + 16])
        for start in range(0, len(flags), 16)
    ]


def timer_text(status: MasterStatus) -> list[str]:
    if status.timers is None and status.counters is None:
        return ["timers   not shown by this master (only an emulated board shows them)"]
    timers = [
        # 0 left is both "never started" and "run out": the board keeps nothing between
        f"T {t.number}: " + (f"running, {format_duration(t.remaining_ms)} left" if t.running
                             else "not running")
        for t in status.timers or []
    ]
    counters = [f"C {c.number}: {c.value}" for c in status.counters or []]
    return [
        "timers   " + ("; ".join(timers) or "(none)"),
        "counters " + ("; ".join(counters) or "(none)"),
    ]


#: The installed-software letters (manual 10.2.5): position -> (capital, lower case).
_SOFTWARE = {
    0: ("control program running", "control program not running"),
    1: ("bus-capable", ""), 2: ("error counters", ""), 3: ("EMC test mode", ""),
    4: ("advanced diagnostics", ""), 5: ("offline on a configuration error", ""),
    8: ("data exchange active", "data exchange off"), 9: ("offline", "online"),
    10: ("auto-address enabled", "auto-address off"), 14: ("watchdog on", "watchdog off"),
}


def software_legend(letters: str) -> str:
    """What the installed-software letters say (capital: yes): ``C control program
    running, B bus-capable, ...``; the unused places are left out."""
    parts = []
    for place, (yes, no) in _SOFTWARE.items():
        letter = letters[place : place + 1]
        if not letter.isalpha():
            continue
        meaning = yes if letter.isupper() else no or f"no {yes}"
        parts.append(f"{letter} {meaning}")
    return ", ".join(parts)


# --------------------------------------------------------------------------- operands

K = ast.OperandKind
#: The operand kinds a status shows the value of (``operand_value``).
VISIBLE = (K.I, K.IB, K.Q, K.QB, K.F, K.FY, K.T, K.C)


def operand_value(status: MasterStatus, operand: Operand) -> int:
    """The operand's value in ``status``; ``UserError`` (exit 1) for a timer or counter on
    a master that does not show them."""
    node = operand.node
    a, bit = node.address, node.bit
    match node.kind:
        case K.F:
            return status.flags[a] >> bit & 1
        case K.FY:
            return status.flags[a]
        case K.I | K.Q:
            data = _data(status, a, node.kind is K.I)
            return data >> bit & 1 if bit >= 0 else data
        case K.IB | K.QB:
            inputs = node.kind is K.IB
            return _data(status, a, inputs) | _data(status, a + 1, inputs) << 4
        case K.T | K.C:
            return _timer_or_counter(status, operand)
        case (K.I2 | K.I2B | K.PSEG | K.FW | K.VAR | K.KT | K.KC | K.KB | K.KW | K.KP):
            raise AssertionError(f"{operand} is not shown by a status")  # callers check VISIBLE
        case _:
            assert_never(node.kind)


def _data(status: MasterStatus, slave: int, inputs: bool) -> int:
    row: SlaveData | None = status.slaves.get(str(slave))
    if row is None:
        return 0
    return row.inputs if inputs else row.outputs


def _timer_or_counter(status: MasterStatus, operand: Operand) -> int:
    node = operand.node
    is_timer = node.kind is K.T
    rows: Sequence[Timer | Counter] | None = status.timers if is_timer else status.counters
    what = "timers" if is_timer else "counters"
    if rows is None:
        raise UserError(f"'{operand}': only an emulated board shows the program's {what}",
                        ExitCode.FAILED)
    row = next((r for r in rows if r.number == node.address), None)
    value = 0 if row is None else row.remaining_ms if isinstance(row, Timer) else row.value
    return int(value != 0) if operand.is_bit else value


def forced_text(status: MasterStatus) -> list[str]:
    """The force list as a PLC's FORCE lamp and force table show it: how many operands
    are forced, and each with its value (and name)."""
    if status.forced is None:
        return []
    if not status.forced:
        return ["forced   (none)"]
    return [f"forced   FORCE {len(status.forced)}: " + ", ".join(map(str, status.forced))]


def symbol_text(status: MasterStatus) -> list[str]:
    """The names the program on the master gives its operands, each with its value where
    the status shows it: ``Lamp (Q 2.0) = 1``."""
    if not status.symbols:
        return []
    parts = []
    for name, text in status.symbols.items():
        operand = parse_operand(text)
        shown = operand.node.kind in VISIBLE and (
            operand.node.kind not in (K.T, K.C) or status.timers is not None)
        parts.append(f"{name} ({text})" + (f" = {operand_value(status, operand)}"
                                           if shown else ""))
    return ["symbols  " + ", ".join(parts)]


def status_events(old: MasterStatus, new: MasterStatus) -> list[str]:
    """What changed between two readings, as the monitor's and the web page's event logs
    say it."""
    events = []
    if old.phase != new.phase:
        events.append(f"phase: {new.phase}")
    if old.mode != new.mode:
        events.append(f"{new.mode} mode")
    if old.config_ok != new.config_ok:
        if new.config_ok:
            events.append("config ok")
        else:
            why = [f"{n} missing" for n in new.missing]
            why += [f"{n} not projected" for n in new.unexpected]
            why += [f"{w.slave} wrong profile" for w in new.wrong_profile]
            events.append("configuration error" + (f": {', '.join(why)}" if why else ""))
    if old.held != new.held:
        events.append(new.held or "running again: the debugger let the program go on")
    if (old.control_state, stop_text(old)) != (new.control_state, stop_text(new)):
        stopped = stop_text(new)
        events.append(f"control program {new.control_state}" + (f" ({stopped})" if stopped else ""))
    joined = sorted(set(new.lds) - set(old.lds))
    left = sorted(set(old.lds) - set(new.lds))
    if joined:
        events.append(f"slaves detected: {', '.join(map(str, joined))}")
    if left:
        events.append(f"slaves lost: {', '.join(map(str, left))}")
    if old.program.identity != new.program.identity and new.program.present:
        events.append(f"program {new.program.identity or 'invalid'}")
    return events


def render(status: MasterStatus) -> str:
    """A text screen: flags on top, the slave lists below, the control program last."""
    s = status
    problems = [f"slave {n} missing" for n in s.missing]
    problems += [f"slave {n} not projected" for n in s.unexpected]
    problems += [
        f"slave {w.slave} is {_profile(w.detected)}, projected {_profile(w.projected)}"
        for w in s.wrong_profile
    ]
    if 0 in s.lds:
        problems.append("a new slave with address 0 is present")
    set_flags = [
        name for name in ("start_flag", "ignore_config_errors", "wait_for_set_button",
                          "map_counters", "control_active") if getattr(s, name)
    ]
    stopped = stop_text(s)
    control = s.held or s.control_state + (f" ({stopped})" if stopped else "")
    p = s.program
    if p.valid:
        program = (
            f"{p.identity}, {p.size} bytes ({p.code_size} of code), source "
            + ("included" if p.source_included else "not included")
        )
    else:
        program = p.problem or "none"
    lines = [
        f"master   {s.master_name}  {s.version_id}  at {s.port}",
        f"software {s.installed_software}"
        + (f"  ({legend})" if (legend := software_legend(s.installed_software)) else ""),
        f"phase    {s.phase}, {s.mode} mode, "
        + ("config ok" if s.config_ok else "no slaves detected yet" if not s.lds
           else "configuration error")
        + (", AS-i power fail" if s.power_fail else ""),
        f"ec-flags {s.ec_flags:02X}h",
        "slaves   " + "".join(str(n // 10) for n in range(SLAVES)),
        "         " + "".join(str(n % 10) for n in range(SLAVES)),
        "    " + _slave_row("LPS", s.lps),
        "    " + _slave_row("LDS", s.lds),
        "    " + _slave_row("LAS", s.las),
        *(["    " + _slave_row("LCS", s.lcs)] if s.lcs is not None else []),
        "    " + _slave_row("LOS", s.los),
        "config   " + ("; ".join(problems) if problems else "no errors" if s.config_ok
                         else "no slaves detected yet" if not s.lds
                         else "the master reports a configuration error"),
        f"display  {s.display.shown()}"
        + ("" if s.panel == "gateway" else " (as a gateway shows this state)"),
        *([f"leds     {led_text(s.leds)}"] if s.leds is not None else []),
        *(["keys     locked (Modbus register 1007)"] if s.keys_locked else []),
        f"control  {control}",
        f"flags    {s.control_flags:02X}h " + (" ".join(set_flags) or "(none)"),
        f"program  {program} ({s.program_status})",
        (f"cycle    {cycle_text(s.cycle_time_ms, s.max_cycle_time_ms)} in 10 µs "
         "units; " + other_reading(raw_value(s.cycle_time_ms), raw_value(s.max_cycle_time_ms))
         if s.cycle_times_known else "cycle    n/a (the gateway does not report them)"),
        f"hi-flags {s.hi_flags:02X}h {hi_flag_text(s.hi_flags)}",
        *timer_text(s),
        *forced_text(s),
        *symbol_text(s),
        "",
        *slave_rows(s.slaves),
        "",
        *flag_rows(s.flags),
    ]
    return "\n".join(lines) + "\n"
