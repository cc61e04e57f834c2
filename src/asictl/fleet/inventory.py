"""The plant's inventory, ``plant.toml``: its masters by name and how each is reached.

Every master becomes a ``MasterAddress`` (host.connection), the same record the board
options of ``download``/``upload`` make, so a fleet command reaches a master exactly as
those commands do. Every problem is a diagnostic at its line and column with the source
line and a caret: tomllib keeps no positions, so each ``[masters.NAME]`` header is found
in the text and a key by its text inside its table (as the scenario reader does).
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity, Span
from asictl.errors import UserError
from asictl.host.connection import MasterAddress
from asictl.host.transports.ports import IO_BACKENDS, parse_port, port_name
from asictl.host.transports.target import DEFAULT_RETRIES, DEFAULT_TIMEOUT_S, parse_target
from asictl.il.suggest import did_you_mean
from asictl.platform.gateway import UNITS
from asictl.source import SourceText

#: A master's name is a folder of the archive: letters, digits and ``-_.``, not hidden.
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
#: How often a master's whole upload is tried before it counts as failed.
DEFAULT_ATTEMPTS = 2
#: Keys a master's table (and ``[defaults]``, which gives any of them to every master) takes.
MASTER_KEYS = (
    "port", "io", "state_dir", "modbus", "unit", "baud", "parity", "stopbits",
    "timeout", "retries", "attempts", "line", "groups",
)
_TOP_KEYS = ("defaults", "masters")
_HEADER = re.compile(r"^\s*\[\s*([^\[\]]*?)\s*\]\s*(#.*)?$")


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


class _Reader:
    """The inventory's text, and where its tables and keys are."""

    def __init__(self, source: SourceText) -> None:
        self.source = source
        self.lines = source.text.split("\n")
        self.problems: list[Diagnostic] = []
        #: table name as written in its header (``masters.press-1``) -> its first line
        self.tables: dict[str, int] = {}
        for number, text in enumerate(self.lines, 1):
            match = _HEADER.match(text)
            if match:
                name = re.sub(r"\s*\.\s*", ".", match[1]).replace('"', "").replace("'", "")
                self.tables.setdefault(name, number)

    def table_range(self, name: str) -> tuple[int, int]:
        """The lines of table ``name``: its header to the next header (the whole file when
        it has no header of its own, as for an inline or dotted table)."""
        first = self.tables.get(name)
        if first is None:
            return 1, len(self.lines)
        later = [n for n in self.tables.values() if n > first]
        return first, (min(later) - 1 if later else len(self.lines))

    def key_span(self, key: str, table: str) -> Span:
        first, last = self.table_range(table)
        pattern = re.compile(rf"^\s*(\"?{re.escape(key)}\"?)\s*=")
        for number in range(first, last + 1):
            match = pattern.match(self.lines[number - 1])
            if match:
                return Span(self.source.name, number, match.start(1) + 1, len(match[1]))
        return self.header_span(table)

    def header_span(self, table: str) -> Span:
        number = self.tables.get(table)
        if number is None:
            return Span(self.source.name, 1, 1)
        text = self.lines[number - 1]
        start = len(text) - len(text.lstrip())
        return Span(self.source.name, number, start + 1, max(1, len(text.rstrip()) - start))

    def error(self, message: str, span: Span) -> None:
        self.problems.append(Diagnostic(Severity.ERROR, ScenarioCode.INVENTORY, message, span))


def read_inventory(source: SourceText) -> Inventory:
    """Parse and check ``plant.toml``; raises ``DiagnosticError`` with every problem."""
    reader = _Reader(source)
    try:
        data = tomllib.loads(source.text)
    except tomllib.TOMLDecodeError as exc:
        at = re.search(r"line (\d+), column (\d+)", str(exc))
        line, column = (int(at[1]), int(at[2])) if at else (1, 1)
        message = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(exc))
        raise DiagnosticError([Diagnostic(
            Severity.ERROR, ScenarioCode.INVENTORY, f"not valid TOML: {message}",
            Span(source.name, line, column),
        )]) from None
    except RecursionError:
        raise DiagnosticError([Diagnostic(
            Severity.ERROR, ScenarioCode.INVENTORY, "not valid TOML: nested too deeply",
            Span(source.name, 1, 1),
        )]) from None
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
    reader: _Reader, table: dict[str, Any], known: tuple[str, ...], where: str, place: str
) -> None:
    for key in sorted(set(table) - set(known)):
        reader.error(
            f"unknown key '{key}'{place}{did_you_mean(key, known)} (known: {', '.join(known)})",
            reader.key_span(key, where),
        )


def _master(
    reader: _Reader, name: str, values: dict[str, Any], own: dict[str, Any], base: Path
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
    timeout = number("timeout", 0.01, 60, DEFAULT_TIMEOUT_S, False)
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
    return FleetMaster(name, address, reached, attempts, line, tuple(groups))
