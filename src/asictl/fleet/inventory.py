"""The plant's inventory, ``plant.toml``: its masters by name and how each is reached.

Every master becomes a ``MasterAddress`` (host.connection), the same record the board
options of ``download``/``upload`` make, so a fleet command reaches a master exactly as
those commands do. Every problem is a diagnostic at its line and column with the source
line and a caret, at the key or table (``readers.tomlfile`` keeps their places).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity, Span
from asictl.errors import UserError
from asictl.host.connection import MasterAddress
from asictl.host.transports.ports import IO_BACKENDS, parse_port, port_name
from asictl.host.transports.target import DEFAULT_RETRIES, DEFAULT_TIMEOUT_S, parse_target
from asictl.platform.gateway import UNITS
from asictl.readers.suggest import did_you_mean
from asictl.readers.tomlfile import Document, read_toml
from asictl.readers.units import UnitError, parse_duration
from asictl.source import SourceText

#: A master's name is a folder of the archive: letters, digits and ``-_.``, not hidden.
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
#: How often a master's whole upload is tried before it counts as failed.
DEFAULT_ATTEMPTS = 2
#: The time a master's whole work may take, every attempt together (seconds): a gateway
#: that answers each request slowly but in time (dripping bytes) fails within it.
DEFAULT_LIMIT_S = 120.0
#: Keys a master's table (and ``[defaults]``, which gives any of them to every master) takes.
MASTER_KEYS = (
    "port", "io", "state_dir", "modbus", "unit", "baud", "parity", "stopbits",
    "timeout", "retries", "attempts", "limit", "line", "groups",
)
_TOP_KEYS = ("defaults", "masters")


@dataclass(frozen=True)
class FleetMaster:
    """One master of the plant: its name, how it is reached, where it stands."""

    name: str
    address: MasterAddress
    #: how it is reached, as the inventory says it: ``port 300h``, ``tcp://host:5020 unit 1``
    reached: str
    attempts: int = DEFAULT_ATTEMPTS
    line: str | None = None
    groups: tuple[str, ...] = ()
    #: seconds the whole work on it may take, every attempt together
    limit: float = DEFAULT_LIMIT_S


@dataclass(frozen=True)
class Inventory:
    path: Path
    masters: tuple[FleetMaster, ...]

    def select(self, lines: tuple[str, ...] = (), groups: tuple[str, ...] = ()) -> list[
        FleetMaster
    ]:
        """The masters on any of ``lines`` or in any of ``groups`` (all when both are empty);
        a line or group no master has is a ``UserError`` (a typo would select nothing)."""
        known_lines = {m.line for m in self.masters if m.line}
        known_groups = {g for m in self.masters for g in m.groups}
        for what, asked, known in (("line", lines, known_lines), ("group", groups, known_groups)):
            for name in asked:
                if name not in known:
                    raise UserError(
                        f"{self.path}: no master is on {what} '{name}'"
                        f"{did_you_mean(name, sorted(known))}"
                        + (f" ({what}s: {', '.join(sorted(known))})" if known else "")
                    )
        if not lines and not groups:
            return list(self.masters)
        return [
            m for m in self.masters
            if m.line in lines or any(g in groups for g in m.groups)
        ]


@dataclass
class _Reading:
    """The inventory's document and what is wrong with it so far. A table is named by
    its dotted path as headers write it: ``""`` the top, ``defaults``, ``masters.NAME``."""

    document: Document
    problems: list[Diagnostic] = field(default_factory=list)

    def key_span(self, key: str, table: str) -> Span:
        return self.document.key((*_path(table), key))

    def header_span(self, table: str) -> Span:
        return self.document.value(_path(table))

    def error(self, message: str, span: Span) -> None:
        self.problems.append(Diagnostic(Severity.ERROR, ScenarioCode.INVENTORY, message, span))


def _path(table: str) -> tuple[str, ...]:
    return tuple(table.split(".", 1)) if table else ()


def read_inventory(source: SourceText) -> Inventory:
    """Parse and check ``plant.toml``; raises ``DiagnosticError`` with every problem."""
    reader = _Reading(read_toml(source.name, source.text))
    data = reader.document.data
    _unknown(reader, data, _TOP_KEYS, "", "")
    defaults = data.get("defaults", {})
    if not isinstance(defaults, dict):
        reader.error("[defaults] is a table", reader.key_span("defaults", ""))
        defaults = {}
    _unknown(reader, defaults, MASTER_KEYS, "defaults", " in [defaults]")
    masters = data.get("masters")
    if not isinstance(masters, dict) or not masters:
        reader.error(
            "the inventory names no masters: give each a table such as [masters.press-1] "
            'with port = "300h" or modbus = "tcp://HOST:PORT"',
            reader.key_span("masters", "") if masters is not None else Span(source.name, 1, 1),
        )
        raise DiagnosticError(reader.problems)
    found: list[FleetMaster] = []
    folders: dict[str, str] = {}
    reaches: dict[tuple[object, ...], str] = {}
    base = Path(source.name).parent
    for name, table in masters.items():
        where = f"masters.{name}"
        if not NAME.fullmatch(name):
            reader.error(
                f"master '{name[:40]}': a name is 1 to 64 letters, digits, '-', '_' or '.', "
                "starting with a letter or digit (it names the master's folder in the archive)",
                reader.header_span(where),
            )
            continue
        if name.lower() in folders:
            reader.error(
                f"master '{name}' and '{folders[name.lower()]}' differ only in case (their "
                "archive folders would be one on some file systems)", reader.header_span(where),
            )
            continue
        folders[name.lower()] = name
        if not isinstance(table, dict):
            reader.error(f"master '{name}' is a table: [masters.{name}]",
                         reader.key_span(name, "masters"))
            continue
        _unknown(reader, table, MASTER_KEYS, where, f" in [masters.{name}]")
        master = _master(reader, name, {**defaults, **table}, table, base)
        if master is None:
            continue
        same = reaches.setdefault(_reach(master), name)
        if same != name:
            reader.error(f"master '{name}' is reached as '{same}' is ({master.reached}): "
                         "one master twice would be backed up twice at once",
                         reader.header_span(where))
            continue
        found.append(master)
    if reader.problems:
        raise DiagnosticError(reader.problems)
    return Inventory(Path(source.name), tuple(found))


def _reach(master: FleetMaster) -> tuple[object, ...]:
    """What tells masters apart: the gateway and unit, or the board's state file."""
    address = master.address
    if address.modbus is not None:
        return ("modbus", address.modbus, address.unit)
    if address.io != "emulated":
        return ("devport", address.port)
    where = address.state_dir
    return ("emulated", str(Path(where).resolve()) if where is not None else None, address.port)


def _unknown(
    reader: _Reading, table: dict[str, Any], known: tuple[str, ...], where: str, place: str
) -> None:
    reader.problems.extend(reader.document.unknown_keys(_path(where), table, known,
                                                       place.strip()))


def _duration(
    reader: _Reading, key: str, value: object, span: Span, low_ms: float, high_ms: float,
    default_s: float, allowed: str,
) -> float:
    """A time in seconds, written with its unit (``"500ms"``) from ``low_ms`` to
    ``high_ms``; a bare number is refused with both readings, as a gateway's time-out was
    once seconds while a number in every other file is milliseconds."""
    if value is None:
        return default_s
    try:
        if isinstance(value, int | float) and not isinstance(value, bool):
            raise UnitError(f"give a unit: \"{value:g}s\" or \"{value:g}ms\"")
        ms = parse_duration(value, limit_ms=high_ms) if isinstance(value, str) else math.nan
        if not ms >= low_ms:
            raise UnitError(allowed)
    except UnitError as exc:
        reader.error(f"{key}: {exc}", span)
        return default_s
    return ms / 1000


def _master(
    reader: _Reading, name: str, values: dict[str, Any], own: dict[str, Any], base: Path
) -> FleetMaster | None:
    """One master's settings (``values``: its own over ``[defaults]``) as a ``FleetMaster``;
    None after reporting what is wrong."""
    before = len(reader.problems)
    table = f"masters.{name}"

    def span(key: str) -> Span:
        return reader.key_span(key, table if key in own else "defaults")

    def number(key: str, low: float, high: float, default: float, integer: bool) -> float:
        value = values.get(key, default)
        kind = int if integer else (int, float)
        if isinstance(value, bool) or not isinstance(value, kind) or not (
            math.isfinite(value) and low <= value <= high
        ):
            what = "a whole number" if integer else "a number"
            reader.error(f"{key} is {what} from {low:g} to {high:g}, not {value!r}"[:200],
                         span(key))
            return default
        return value

    def text(key: str) -> str | None:
        value = values.get(key)
        if value is not None and (not isinstance(value, str) or not value or "\0" in value):
            reader.error(f"{key} is a non-empty string", span(key))
            return None
        return value

    port, modbus = text("port"), text("modbus")
    if ("port" in values) == ("modbus" in values):
        reader.error(
            f"master '{name}': give either port = \"300h\" (a PC2 board) or modbus = "
            '"tcp://HOST:PORT" (a gateway)' + (", not both" if port and modbus else ""),
            reader.header_span(table),
        )
    unit = int(number("unit", UNITS[0], UNITS[-1], 1, True))
    timeout = _duration(reader, "timeout", values.get("timeout"), span("timeout"), 10, 60_000,
                        DEFAULT_TIMEOUT_S, 'a time from 10ms to 60s, such as "500ms"')
    limit = _duration(reader, "limit", values.get("limit"), span("limit"), 1000, 3_600_000,
                      DEFAULT_LIMIT_S, 'a time from 1s to 1h, such as "30s"')
    retries = int(number("retries", 0, 20, DEFAULT_RETRIES, True))
    attempts = int(number("attempts", 1, 10, DEFAULT_ATTEMPTS, True))
    baud = int(number("baud", 1, 10**6, 9600, True))
    stopbits = int(number("stopbits", 1, 2, 1, True))
    parity = text("parity") or "N"
    io = text("io") or "emulated"
    if io not in IO_BACKENDS:
        reader.error(f"io is one of {', '.join(IO_BACKENDS)}, not '{io[:40]}'", span("io"))
    state_dir = text("state_dir")
    line = text("line")
    groups = values.get("groups", [])
    if not isinstance(groups, list) or not all(isinstance(g, str) and g for g in groups):
        reader.error('groups is a list of names: groups = ["presses"]', span("groups"))
        groups = []
    reached = ""
    if port is not None and modbus is None:
        for key in ("unit", "baud", "parity", "stopbits"):
            if key in own:
                reader.error(f"{key} is for a gateway (modbus = ...), not a PC2 board",
                             span(key))
        try:
            port = port_name(parse_port(port))
        except UserError as exc:
            reader.error(str(exc), span("port"))
        reached = f"port {port}" + (f" ({io})" if io != "emulated" else "")
    elif modbus is not None and port is None:
        for key in ("io", "state_dir"):
            if key in own:
                reader.error(f"{key} is for a PC2 board (port = ...), not a gateway", span(key))
        try:
            target = parse_target(modbus, baud=baud, parity=parity, stopbits=stopbits)
        except UserError as exc:
            reader.error(str(exc).replace("--modbus", "modbus"), span("modbus"))
        else:
            if target.device is None:
                for key in ("baud", "parity", "stopbits"):
                    if key in own:
                        reader.error(f"{key} is for a serial device, not {modbus[:40]}",
                                     span(key))
        reached = f"{modbus} unit {unit}"
    if len(reader.problems) > before:
        return None
    directory = None if state_dir is None else base / Path(state_dir).expanduser()
    address = MasterAddress(
        port=port or "300h", io=io, state_dir=directory, modbus=modbus, unit=unit, baud=baud,
        parity=parity, stopbits=stopbits, timeout=timeout, retries=retries,
    )
    return FleetMaster(name, address, reached, attempts, line, tuple(groups), limit)
