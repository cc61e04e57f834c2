"""Scenario files: inputs over time, expected outputs, bus changes (TOML).

The schema is a contract (docs/simulation.md). Every problem in a scenario is reported
as a diagnostic at its line in the file: tomllib does not keep positions, so one pass
over the text finds where each step starts (its ``[[step]]`` header, or its ``{`` in an
inline ``step = [...]`` array) and keys are found by their text within their step.
Numbers are checked against the documented ranges before anything is simulated: a
simulation of a billion years, a cycle of no time or a NaN never starts.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Reporter, Severity, Span
from asictl.il.suggest import did_you_mean
from asictl.observe.condition import Condition, ConditionError, parse_condition
from asictl.observe.operands import Operand, check_value, parse_operand
from asictl.observe.symbols import SymbolTable
from asictl.readers.profile import read_profile
from asictl.readers.strings import value_column
from asictl.sim.plant import Model, Plant, read_model
from asictl.source import SourceText, read_source

_DURATION = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*(ms|s|m|min|h)?\s*$", re.IGNORECASE)
_UNIT_MS = {"ms": 1, "s": 1000, "m": 60_000, "min": 60_000, "h": 3_600_000, None: 1000}

#: The longest stretch of master time a simulation covers: one day.
MAX_TIME_MS = 24 * 3_600_000.0
#: The program cycle period a scenario may set, in milliseconds.
MIN_CYCLE_MS, MAX_CYCLE_MS = 0.1, 10_000.0
#: Arrays and inline tables nested deeper than this are refused (a scenario needs 3).
MAX_NESTING = 32


def parse_duration(text: str) -> float:
    """'250ms', '10s', '2m', '1h' (a bare number is seconds) -> milliseconds, at most
    ``MAX_TIME_MS``."""
    match = _DURATION.match(text) if len(text) < 100 else None
    if not match:
        raise ValueError(f"'{text[:40]}' is not a duration (examples: 250ms, 10s, 2m, 1h)")
    unit = match[2].lower() if match[2] else None
    ms = float(match[1]) * _UNIT_MS[unit]
    if not ms <= MAX_TIME_MS:
        raise ValueError(f"'{text}' is longer than the longest simulation, 24h")
    return ms


def check_time(value: object) -> float | None:
    """A step time in milliseconds from TOML (0..MAX_TIME_MS, finite), else None."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    if isinstance(value, int) and not 0 <= value <= MAX_TIME_MS:
        return None
    ms = float(value)
    return ms if math.isfinite(ms) and 0 <= ms <= MAX_TIME_MS else None


@dataclass(frozen=True)
class SlaveSpec:
    """A slave as a scenario puts it on the bus: ``"iiio,1"`` or ``"Bh,0,Eh"``."""

    address: int
    io_code: int
    id_code: int
    parameter: int = 0xF


@dataclass
class Step:
    at_ms: float
    line: int
    set: list[tuple[Operand, int, int]] = field(default_factory=list)  # operand, value, line
    expect: list[tuple[Operand, int, int]] = field(default_factory=list)
    #: (line, operand) -> the name the scenario wrote, where it was a symbol
    written: dict[tuple[int, str], str] = field(default_factory=dict)
    add_slaves: list[SlaveSpec] = field(default_factory=list)
    remove_slaves: list[int] = field(default_factory=list)
    power_fail: bool | None = None
    press_set_button: bool = False
    #: the expectations' tolerance: each holds if its value is seen within this long
    #: before or after ``at_ms`` (0: exactly at ``at_ms``)
    within_ms: float = 0.0


@dataclass
class Scenario:
    file: str
    program: Path | None
    cycle_ms: float | None
    slaves: list[SlaveSpec] | None
    steps: list[Step]
    #: test markers (``markers = ["slow"]``) for test runners
    markers: list[str] = field(default_factory=list)
    #: the ``[[plant]]`` models, as read (a simulation runs copies)
    plants: list[Model] = field(default_factory=list)

    @property
    def end_ms(self) -> float:
        """The last step's time, or the end of the last tolerance window."""
        return max((s.at_ms + s.within_ms for s in self.steps), default=0.0)

    def ordered(self) -> list[Step]:
        """Steps by time; at equal times the file's order (sets are applied before checks
        by the engine)."""
        return sorted(self.steps, key=lambda s: s.at_ms)


_TOP_KEYS = ("program", "master", "step", "markers", "plant")
_MASTER_KEYS = ("cycle_ms", "slaves")
_STEP_KEYS = {"at_ms", "at", "set", "expect", "add_slaves", "remove_slaves", "power_fail",
              "press_set_button", "within_ms"}


class _Reader:
    def __init__(
        self, source: SourceText, variables: Mapping[str, int] | None, symbols: SymbolTable
    ) -> None:
        self.source = source
        self.lines = source.text.split("\n")
        self.report = Reporter()
        self.variables = variables
        self.symbols = symbols
        layout = _scan(source.text)
        self.too_deep = layout.too_deep
        self.step_lines = layout.step_lines
        self.plant_lines = layout.plant_lines
        self.headers = layout.headers

    def span(self, line: int, column: int = 1) -> Span:
        return Span(self.source.name, line, column)

    def error(self, message: str, line: int, column: int = 1) -> None:
        self.report.error(ScenarioCode.INVALID, message, self.span(line, column))

    def find(self, text: str, start: int, end: int) -> int:
        """The line of ``text`` between two lines (1-based, inclusive), else ``start``."""
        for number in range(start, min(end, len(self.lines)) + 1):
            if text in self.lines[number - 1]:
                return number
        return start

    def key_line(self, key: str, start: int, end: int) -> int:
        return self.key_at(key, start, end)[0]

    def key_at(self, key: str, start: int, end: int) -> tuple[int, int]:
        """Line and column of a key in the lines ``start``..``end`` (its quoted form first)."""
        for form in (f'"{key}"', f"'{key}'"):
            line = self.find(form, start, end)
            text = self.lines[line - 1] if 0 < line <= len(self.lines) else ""
            if form in text:
                return line, text.index(form) + 1
        bare = re.compile(rf"(?:^|[\s{{,])(?P<key>{re.escape(key)})\s*=")  # not at in at_ms =
        for number in range(start, min(end, len(self.lines)) + 1):
            found = bare.search(self.lines[number - 1])
            if found:
                return number, found.start("key") + 1
        return start, 1


def _slave(reader: _Reader, address: object, spec: object, line: int) -> SlaveSpec | None:
    try:
        return parse_slave(address, spec)
    except ValueError as exc:
        reader.error(str(exc), line)
        return None


def parse_slave(address: object, spec: object) -> SlaveSpec:
    """A slave as ``[master] slaves`` names it: address 1..31 and ``"iiio,1"`` (I/O code,
    ID, optional parameter, as in [SETUP]); ``ValueError`` says what is wrong."""
    try:
        number = int(str(address))  # TOML keys are strings
    except ValueError:
        raise ValueError(f"slave address '{address}' is not a number") from None
    if not isinstance(spec, str):
        raise ValueError(f"slave {number}: expected a string like \"iiio,1\", got {spec!r}")
    if not 1 <= number <= 31:
        raise ValueError(f"slave {number}: address 1..31 expected")
    try:
        profile = read_profile(spec)
    except ValueError as exc:
        raise ValueError(f"slave {number}: {exc}") from None
    parameter = 0xF if profile.parameter is None else profile.parameter
    return SlaveSpec(number, profile.io_code, profile.id_code, parameter)


def _slaves(reader: _Reader, table: object, line: int, end: int) -> list[SlaveSpec]:
    if not isinstance(table, dict):
        reader.error("slaves are a table: { 16 = \"iiio,1\" }", line)
        return []
    found: dict[int, SlaveSpec] = {}
    for address, spec in table.items():
        where = reader.key_line(str(address), line, end)
        slave = _slave(reader, address, spec, where)
        if slave is None:
            continue
        if slave.address in found:  # "031" and "31" are one address
            reader.error(f"slave {slave.address} is given twice ('{address}')", where)
            continue
        found[slave.address] = slave
    return list(found.values())


def _operands(
    reader: _Reader, table: object, what: str, line: int, end: int, *, settable: bool,
    written: dict[tuple[int, str], str],
) -> list[tuple[Operand, int, int]]:
    if not isinstance(table, dict):
        reader.error(f"'{what}' is a table of operands: {{ \"I 4.0\" = 1 }}", line)
        return []
    found = []
    for key, value in table.items():
        at, column = reader.key_at(key, line, end)
        try:
            operand = parse_operand(key, reader.variables, reader.symbols)
        except ValueError as exc:
            reader.error(str(exc), at, column)
            continue
        if isinstance(value, bool) or not isinstance(value, int):
            reader.error(f"'{key}': expected a whole number, got {value!r}", at, column)
            continue
        try:
            check_value(value, operand, key)
        except ValueError as exc:
            reader.error(str(exc), at, column)
            continue
        if settable and not operand.settable:
            reader.error(
                f"'{key}' cannot be set: a scenario sets inputs (I, IB) and flags (F, FY)",
                at, column,
            )
            continue
        found.append((operand, value, at))
        if key.strip() != str(operand):
            written[(at, str(operand))] = key
    return found


def _step(reader: _Reader, index: int, data: object) -> Step | None:
    line = reader.step_lines[index] if index < len(reader.step_lines) else 1
    end = reader.step_lines[index + 1] - 1 if index + 1 < len(reader.step_lines) else len(
        reader.lines
    )
    if not isinstance(data, dict):
        reader.error("a step is a table", line)
        return None
    _unknown_keys(reader, data, _STEP_KEYS, "in a step", line, end)
    if "at_ms" not in data and "at" not in data:
        reader.error("each step needs at_ms = <milliseconds, 0 or more>", line)
        return None
    if "at_ms" in data and "at" in data:
        reader.error("a step has one time: at_ms or at, not both", reader.key_line("at", line, end))
        return None
    name = "at_ms" if "at_ms" in data else "at"
    raw = data[name]
    at: float | None
    if isinstance(raw, str):
        try:
            at = parse_duration(raw)
        except ValueError as exc:
            reader.error(str(exc), reader.key_line(name, line, end))
            return None
    else:
        at = check_time(raw)
    if at is None:
        reader.error(f"{name} is a time in milliseconds from 0 to {MAX_TIME_MS:.0f} (24 h), "
                     f"not {_show(raw)}", reader.key_line(name, line, end))
        return None
    step = Step(at, line)
    if "set" in data:
        step.set = _operands(reader, data["set"], "set", reader.key_line("set", line, end), end,
                             settable=True, written=step.written)
    if "expect" in data:
        step.expect = _operands(reader, data["expect"], "expect",
                                reader.key_line("expect", line, end), end, settable=False,
                                written=step.written)
    if "add_slaves" in data:
        step.add_slaves = _slaves(reader, data["add_slaves"],
                                  reader.key_line("add_slaves", line, end), end)
    if "remove_slaves" in data:
        removed = data["remove_slaves"]
        if not isinstance(removed, list) or not all(
            isinstance(a, int) and 0 <= a <= 31 for a in removed
        ):
            reader.error("remove_slaves is a list of addresses 0..31",
                         reader.key_line("remove_slaves", line, end))
        else:
            step.remove_slaves = list(removed)
    if "within_ms" in data:
        within = check_time(data["within_ms"])
        where = reader.key_line("within_ms", line, end)
        if within is None:
            reader.error(f"within_ms is a time in milliseconds from 0 to {MAX_TIME_MS:.0f}, "
                         f"not {_show(data['within_ms'])}", where)
        elif "expect" not in data:
            reader.error("within_ms is the tolerance of the step's expect, and the step has "
                         "none", where)
        elif at + within > MAX_TIME_MS:
            reader.error("the tolerance window ends after the longest simulation, 24h", where)
        else:
            step.within_ms = within
    for flag in ("power_fail", "press_set_button"):
        if flag in data:
            if not isinstance(data[flag], bool):
                reader.error(f"{flag} is true or false", reader.key_line(flag, line, end))
            elif flag == "power_fail":
                step.power_fail = data[flag]
            else:
                step.press_set_button = data[flag]
    return step


def _unknown_keys(
    reader: _Reader, table: dict[str, object], known: Iterable[str], where: str,
    first: int, last: int,
) -> None:
    """Each key of ``table`` that is not ``known``, at its line, with the closest known one
    (``cycle_m`` -> ``cycle_ms``)."""
    names = sorted(known)
    place = f" {where}" if where else ""
    for unknown in sorted(set(table) - set(names)):
        reader.error(
            f"unknown key '{unknown}'{place}{did_you_mean(unknown, names)} "
            f"(known: {', '.join(names)})",
            reader.key_line(unknown, first, last),
        )


def _toml(reader: _Reader) -> dict[str, object]:
    """The scenario's TOML, or a ``DiagnosticError`` at the line where it is not TOML."""
    if reader.too_deep:
        raise DiagnosticError([Diagnostic(
            Severity.ERROR, ScenarioCode.NOT_TOML,
            f"arrays or tables nested more than {MAX_NESTING} deep", reader.span(reader.too_deep),
        )])
    try:
        return tomllib.loads(reader.source.text)
    except ValueError as exc:  # TOMLDecodeError, or a number Python will not convert
        if not isinstance(exc, tomllib.TOMLDecodeError):
            raise DiagnosticError([Diagnostic(
                Severity.ERROR, ScenarioCode.NOT_TOML, f"not valid TOML: {exc}",
                reader.span(1),
            )]) from None
        where = re.search(r"line (\d+), column (\d+)", str(exc))
        line, column = (int(where[1]), int(where[2])) if where else (1, 1)
        message = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(exc))
        raise DiagnosticError([
            Diagnostic(Severity.ERROR, ScenarioCode.NOT_TOML, f"not valid TOML: {message}",
                       reader.span(line, column))
        ]) from None


def scenario_program(source: SourceText) -> Path | None:
    """The program a scenario names (``program = "..."``, relative to the scenario), read
    before the program's variables and symbols are known. Raises ``DiagnosticError`` for
    a file that is not TOML or names it wrongly."""
    reader = _Reader(source, None, SymbolTable())
    program = _toml(reader).get("program")
    if program is None:
        return None
    if not _is_file_name(program):
        raise DiagnosticError([Diagnostic(
            Severity.ERROR, ScenarioCode.INVALID, _PROGRAM_NAME,
            reader.span(reader.key_line("program", 1, len(reader.lines))),
        )])
    return Path(source.name).parent / str(program)


_PROGRAM_NAME = "program is a file name (not empty, no NUL characters)"


def _is_file_name(value: object) -> bool:
    return isinstance(value, str) and value != "" and "\0" not in value


def read_scenario(
    source: SourceText,
    variables: Mapping[str, int] | None = None,
    symbols: SymbolTable | None = None,
) -> Scenario:
    """Parse and validate a scenario; ``variables`` (the program's: key name -> size in
    bytes) resolve variable operands, ``symbols`` the names of its symbol table.

    Raises ``DiagnosticError`` with every problem found.
    """
    reader = _Reader(source, variables, symbols or SymbolTable())
    data = _toml(reader)
    _unknown_keys(reader, data, _TOP_KEYS, "", 1, len(reader.lines))
    markers = data.get("markers", [])
    if not isinstance(markers, list) or not all(
        isinstance(m, str) and re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", m) for m in markers
    ):
        reader.error('markers is a list of names: markers = ["slow"]',
                     reader.key_line("markers", 1, len(reader.lines)))
        markers = []
    program_path = None
    if "program" in data:
        if _is_file_name(data["program"]):
            program_path = Path(source.name).parent / str(data["program"])
        else:
            reader.error(_PROGRAM_NAME, reader.key_line("program", 1, len(reader.lines)))
    master = data.get("master", {})
    cycle_ms = slaves = None
    master_line = reader.find("[master]", 1, len(reader.lines))
    if not isinstance(master, dict):
        reader.error("[master] is a table", master_line)
        master = {}
    _unknown_keys(reader, master, _MASTER_KEYS, "in [master]", master_line, len(reader.lines))
    if "cycle_ms" in master:
        value = master["cycle_ms"]
        cycle_ms = _cycle(value)
        if cycle_ms is None:
            reader.error(f"cycle_ms is a time in milliseconds from {MIN_CYCLE_MS:g} to "
                         f"{MAX_CYCLE_MS:g}, not {_show(value)}",
                         reader.key_line("cycle_ms", master_line, len(reader.lines)))
    if "slaves" in master:
        end = reader.step_lines[0] - 1 if reader.step_lines else len(reader.lines)
        slaves = _slaves(reader, master["slaves"],
                         reader.key_line("slaves", master_line, end), end)
    raw_steps = data.get("step", [])
    if not isinstance(raw_steps, list):
        reader.error("steps are [[step]] tables", 1)
        raw_steps = []
    steps = [s for i, d in enumerate(raw_steps) if (s := _step(reader, i, d))]
    plants = _plants(reader, data.get("plant", []), steps)
    if reader.report.has_errors:
        raise DiagnosticError(reader.report.diagnostics)
    return Scenario(source.name, program_path, cycle_ms, slaves, steps, list(markers), plants)


class _PlantPlace:
    """A ``[[plant]]`` table's lines, for ``plant.read_model``'s problems."""

    def __init__(self, reader: _Reader, line: int, end: int) -> None:
        self.reader = reader
        self.line = line
        self.end = end

    def problem(self, message: str, key: str | None = None) -> None:
        line, column = self.reader.key_at(key, self.line, self.end) if key else (self.line, 1)
        self.reader.error(message, line, column)

    def condition_problem(self, error: ConditionError, key: str) -> None:
        line, column = self.reader.key_at(key, self.line, self.end)
        text = self.reader.lines[line - 1] if 0 < line <= len(self.reader.lines) else ""
        column = value_column(text, column, error.offset) or column
        self.reader.report.error(ScenarioCode.CONDITION, error.message,
                                 Span(self.reader.source.name, line, column, error.length))

    def operand(self, text: str) -> Operand:
        return parse_operand(text, self.reader.variables, self.reader.symbols)

    def condition(self, text: str) -> Condition:
        return parse_condition(text, self.reader.variables, self.reader.symbols)


def _plants(reader: _Reader, raw: object, steps: list[Step]) -> list[Model]:
    """The ``[[plant]]`` models; a model writing an input another one writes, or that a
    step sets, is an error (at that step's key)."""
    lines = reader.plant_lines
    if not isinstance(raw, list) or not all(isinstance(t, dict) for t in raw):
        reader.error("plant models are [[plant]] tables", lines[0] if lines else 1)
        return []
    plant = Plant()
    counts: dict[str, int] = {}
    for index, table in enumerate(raw):
        line = lines[index] if index < len(lines) else 1
        later = [h for h in (*reader.headers, *lines) if h > line]
        place = _PlantPlace(reader, line, min(later, default=len(reader.lines) + 1) - 1)
        kind = str(table.get("type", "plant"))
        counts[kind] = counts.get(kind, 0) + 1
        model = read_model(table, f"{kind}{counts[kind]}", place)
        if model is None:
            continue
        model.line = line
        try:
            plant.add(model)
        except ValueError as exc:
            place.problem(str(exc))
    for step in steps:
        for operand, _, line in step.set:
            driver = plant.driver_of(operand)
            if driver is not None:
                written = step.written.get((line, str(operand)), str(operand))
                at, column = reader.key_at(written, line, line)
                reader.error(f"'{written}' is driven by the plant model {driver.name}: a step "
                             "cannot set it", at, column)
    return plant.models


def load_scenario(
    path: str | Path,
    variables: Mapping[str, int] | None = None,
    symbols: SymbolTable | None = None,
) -> Scenario:
    return read_scenario(read_source(path), variables, symbols)


def _cycle(value: object) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    if isinstance(value, int) and not MIN_CYCLE_MS <= value <= MAX_CYCLE_MS:
        return None
    ms = float(value)
    return ms if MIN_CYCLE_MS <= ms <= MAX_CYCLE_MS else None  # NaN fails both


def _show(value: object) -> str:
    """A value for a message, however long it is."""
    text = value if isinstance(value, str) else repr(value)
    try:
        shown = str(text)
    except ValueError:  # an int too long to print
        return "a number far out of range"
    return shown if len(shown) <= 30 else shown[:27] + "..."


@dataclass
class _Layout:
    """What one pass over the text finds: each step's first line, and the first line
    where brackets nest too deep (0: nowhere)."""

    step_lines: list[int]
    too_deep: int = 0
    #: each ``[[plant]]`` table's first line (or its ``{`` in a ``plant = [...]`` array)
    plant_lines: list[int] = field(default_factory=list)
    #: the line of every table header (``[master]``, ``[[step]]``, ...), where a table ends
    headers: list[int] = field(default_factory=list)


_STEP_HEADER = re.compile(r"\s*\[\[\s*step\s*\]\]")
_STEP_ARRAY = re.compile(r"\s*step\s*=\s*\[")
_PLANT_HEADER = re.compile(r"\s*\[\[\s*plant\s*\]\]")
_PLANT_ARRAY = re.compile(r"\s*plant\s*=\s*\[")
_HEADER = re.compile(r"\s*\[")


def _scan(text: str) -> _Layout:
    """Walk the text once, skipping strings and comments, counting brackets.

    Steps are ``[[step]]`` headers at the start of a line, or the ``{`` of each element
    of a top-level ``step = [...]`` array; both forms give the step's line in time linear
    in the file's length, whatever the number of steps.
    """
    layout = _Layout([])
    depth = 0
    array_depth = -1  # the bracket depth inside an inline step array, while in one
    array_lines = layout.step_lines  # where that array's elements are noted
    line = 1
    i, n = 0, len(text)
    at_line_start = True
    while i < n:
        c = text[i]
        if at_line_start and depth == 0:
            end = text.find("\n", i)
            rest = text[i : n if end < 0 else end]
            if _STEP_HEADER.match(rest):
                layout.step_lines.append(line)
            elif _PLANT_HEADER.match(rest):
                layout.plant_lines.append(line)
            elif _STEP_ARRAY.match(rest) or _PLANT_ARRAY.match(rest):
                array_depth = 1
                array_lines = layout.step_lines if _STEP_ARRAY.match(rest) \
                    else layout.plant_lines
            if _HEADER.match(rest):
                layout.headers.append(line)
        at_line_start = False
        if c == "\n":
            line += 1
            at_line_start = True
        elif c == "#":
            end = text.find("\n", i)
            i = n if end < 0 else end
            continue
        elif c in "\"'":
            i, line = _skip_string(text, i, line)
            continue
        elif c in "[{":
            depth += 1
            if depth > MAX_NESTING and not layout.too_deep:
                layout.too_deep = line
            if c == "{" and array_depth >= 0 and depth == array_depth + 1:
                array_lines.append(line)
        elif c in "]}":
            depth = max(0, depth - 1)
            if array_depth >= 0 and depth < array_depth:
                array_depth = -1
        i += 1
    return layout


def _skip_string(text: str, i: int, line: int) -> tuple[int, int]:
    """Past the string starting at ``i`` (basic, literal or multi-line); its newlines
    counted."""
    quote = text[i]
    if text.startswith(quote * 3, i):
        end = text.find(quote * 3, i + 3)
        while quote == '"' and end > 0 and _escaped(text, end):
            end = text.find(quote * 3, end + 1)
        stop = len(text) if end < 0 else end + 3
        while stop < len(text) and text[stop] == quote:  # """a"""" ends at the last quote
            stop += 1
    else:
        j = i + 1
        while j < len(text) and text[j] not in (quote, "\n"):
            j += 2 if quote == '"' and text[j] == "\\" else 1
        stop = min(j + 1, len(text))
    return stop, line + text.count("\n", i, stop)


def _escaped(text: str, at: int) -> bool:
    backslashes = 0
    while at - backslashes - 1 >= 0 and text[at - backslashes - 1] == "\\":
        backslashes += 1
    return backslashes % 2 == 1
