"""Scenario files: inputs over time, expected outputs, bus changes (TOML).

The schema is a contract (docs/simulation.md). Every problem in a scenario is reported
as a diagnostic at its key or value in the file (``readers.tomlfile`` keeps the place of
each). Times are read as ``readers.units`` reads every duration: ``at`` is a number of
milliseconds or a text with its unit (``"2s"``), ``at_ms`` a number of milliseconds only.
Numbers are checked against the documented ranges before anything is simulated: a
simulation of a billion years, a cycle of no time or a NaN never starts.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from asictl.codes import ScenarioCode
from asictl.diagnostics import DiagnosticError, Reporter
from asictl.observe.condition import Condition, ConditionError, parse_condition
from asictl.observe.operands import Operand, check_value, parse_operand
from asictl.observe.symbols import SymbolTable
from asictl.platform.master import TICK_US
from asictl.readers.profile import read_profile
from asictl.readers.tomlfile import Document, KeyPath, read_toml
from asictl.readers.units import UnitError, duration_ms
from asictl.sim.plant import Model, Plant, read_model
from asictl.source import SourceText, read_source

#: The longest stretch of master time a simulation covers: one day.
MAX_TIME_MS = 24 * 3_600_000.0
#: The program cycle period a scenario may set, in milliseconds.
MIN_CYCLE_MS, MAX_CYCLE_MS = 0.1, 10_000.0


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
    #: the time from time 0 to the master's first 10 ms tick (None: as the start-up
    #: leaves it), so that a run that depends on the clock's phase replays
    first_tick_ms: float | None = None

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
#: only in a scenario: a proof holds for every phase of the clock
_SCENARIO_MASTER_KEYS = (*_MASTER_KEYS, "first_tick_ms")
_STEP_KEYS = {"at_ms", "at", "set", "expect", "add_slaves", "remove_slaves", "power_fail",
              "press_set_button", "within_ms", "within"}


@dataclass
class _Reading:
    """A scenario being read: its document, what is wrong so far, and how operands
    resolve (the program's variables and symbols)."""

    document: Document
    variables: Mapping[str, int] | None
    symbols: SymbolTable
    report: Reporter = field(default_factory=Reporter)
    #: (line, operand) of each operand a step sets -> its path, for later problems
    set_paths: dict[tuple[int, str], KeyPath] = field(default_factory=dict)

    def error(self, message: str, path: KeyPath, *, at_value: bool = False) -> None:
        self.report.diagnostics.append(
            self.document.error(ScenarioCode.INVALID, message, path, at_value=at_value))


def _slave(reading: _Reading, address: object, spec: object, path: KeyPath
           ) -> SlaveSpec | None:
    try:
        return parse_slave(address, spec)
    except ValueError as exc:
        reading.error(str(exc), path)
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


def _slaves(reading: _Reading, table: object, path: KeyPath) -> list[SlaveSpec]:
    if not isinstance(table, dict):
        reading.error("slaves are a table: { 16 = \"iiio,1\" }", path)
        return []
    found: dict[int, SlaveSpec] = {}
    for address, spec in table.items():
        where = (*path, address)
        slave = _slave(reading, address, spec, where)
        if slave is None:
            continue
        if slave.address in found:  # "031" and "31" are one address
            reading.error(f"slave {slave.address} is given twice ('{address}')", where)
            continue
        found[slave.address] = slave
    return list(found.values())


def _operands(
    reading: _Reading, table: object, path: KeyPath, *, settable: bool,
    written: dict[tuple[int, str], str],
) -> list[tuple[Operand, int, int]]:
    if not isinstance(table, dict):
        reading.error(f"'{path[-1]}' is a table of operands: {{ \"I 4.0\" = 1 }}", path)
        return []
    found = []
    for key, value in table.items():
        where = (*path, key)
        try:
            operand = parse_operand(key, reading.variables, reading.symbols)
        except ValueError as exc:
            reading.error(str(exc), where)
            continue
        if isinstance(value, bool) or not isinstance(value, int):
            reading.error(f"'{key}': expected a whole number, got {value!r}", where)
            continue
        try:
            check_value(value, operand, key)
        except ValueError as exc:
            reading.error(str(exc), where)
            continue
        if settable and not operand.settable:
            reading.error(
                f"'{key}' cannot be set: a scenario sets inputs (I, IB) and flags (F, FY)",
                where,
            )
            continue
        line = reading.document.key(where).line
        found.append((operand, value, line))
        reading.set_paths[(line, str(operand))] = where
        if key.strip() != str(operand):
            written[(line, str(operand))] = key
    return found


def _time(reading: _Reading, data: Mapping[str, object], path: KeyPath, *, ms: str,
          unit: str, what: str) -> float | None:
    """A time written as ``ms`` (a number of milliseconds) or ``unit`` (a number of
    milliseconds or a text with its unit), ``MAX_TIME_MS`` at most; None if absent or
    wrong (reported)."""
    if ms in data and unit in data:
        reading.error(f"{what} is {ms} or {unit}, not both", (*path, unit))
        return None
    if ms in data:
        found = check_time(data[ms])
        if found is None:
            hint = (f"; for a time with a unit write {unit} = \"{_show(data[ms])}\""
                    if isinstance(data[ms], str) else "")
            reading.error(f"{ms} is a time in milliseconds from 0 to {MAX_TIME_MS:.0f} "
                          f"(24 h), not {_show(data[ms])}{hint}", (*path, ms), at_value=True)
        return found
    if unit in data:
        try:
            return duration_ms(data[unit], limit_ms=MAX_TIME_MS)
        except UnitError as exc:
            reading.error(f"{unit}: {exc}", (*path, unit), at_value=True)
    return None


def _step(reading: _Reading, index: int, data: object) -> Step | None:
    path: KeyPath = ("step", index)
    line = reading.document.key(path).line
    if not isinstance(data, dict):
        reading.error("a step is a table", path)
        return None
    reading.report.extend(reading.document.unknown_keys(path, data, _STEP_KEYS, "in a step"))
    if "at_ms" not in data and "at" not in data:
        reading.error('each step needs a time: at = "2s" (or at_ms = 2000)', path)
        return None
    at = _time(reading, data, path, ms="at_ms", unit="at", what="a step's time")
    if at is None:
        return None
    step = Step(at, line)
    if "set" in data:
        step.set = _operands(reading, data["set"], (*path, "set"), settable=True,
                             written=step.written)
    if "expect" in data:
        step.expect = _operands(reading, data["expect"], (*path, "expect"), settable=False,
                                written=step.written)
    if "add_slaves" in data:
        step.add_slaves = _slaves(reading, data["add_slaves"], (*path, "add_slaves"))
    if "remove_slaves" in data:
        removed = data["remove_slaves"]
        if not isinstance(removed, list) or not all(
            isinstance(a, int) and 0 <= a <= 31 for a in removed
        ):
            reading.error("remove_slaves is a list of addresses 0..31",
                          (*path, "remove_slaves"))
        else:
            step.remove_slaves = list(removed)
    within = _time(reading, data, path, ms="within_ms", unit="within", what="a tolerance")
    if within is not None:
        where = (*path, "within_ms" if "within_ms" in data else "within")
        if "expect" not in data:
            reading.error(f"{where[-1]} is the tolerance of the step's expect, and the step "
                          "has none", where)
        elif at + within > MAX_TIME_MS:
            reading.error("the tolerance window ends after the longest simulation, 24h",
                          where)
        else:
            step.within_ms = within
    for flag in ("power_fail", "press_set_button"):
        if flag in data:
            if not isinstance(data[flag], bool):
                reading.error(f"{flag} is true or false", (*path, flag))
            elif flag == "power_fail":
                step.power_fail = data[flag]
            else:
                step.press_set_button = data[flag]
    return step


def scenario_program(source: SourceText) -> Path | None:
    """The program a scenario names (``program = "..."``, relative to the scenario), read
    before the program's variables and symbols are known. Raises ``DiagnosticError`` for
    a file that is not TOML or names it wrongly."""
    document = read_toml(source.name, source.text)
    program = document.data.get("program")
    if program is None:
        return None
    if not _is_file_name(program):
        raise DiagnosticError([document.error(ScenarioCode.INVALID, _PROGRAM_NAME,
                                              ("program",))])
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
    document = read_toml(source.name, source.text)
    reading = _Reading(document, variables, symbols or SymbolTable())
    data = document.data
    reading.report.extend(document.unknown_keys((), data, _TOP_KEYS))
    markers = data.get("markers", [])
    if not isinstance(markers, list) or not all(
        isinstance(m, str) and re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", m) for m in markers
    ):
        reading.error('markers is a list of names: markers = ["slow"]', ("markers",))
        markers = []
    program_path = None
    if "program" in data:
        if _is_file_name(data["program"]):
            program_path = Path(source.name).parent / str(data["program"])
        else:
            reading.error(_PROGRAM_NAME, ("program",))
    cycle_ms, slaves, first_tick_ms = read_master(document, reading.report,
                                                  ScenarioCode.INVALID, scenario=True)
    raw_steps = data.get("step", [])
    if not isinstance(raw_steps, list):
        reading.error("steps are [[step]] tables", ("step",))
        raw_steps = []
    steps = [s for i, d in enumerate(raw_steps) if (s := _step(reading, i, d))]
    plants = _plants(reading, data.get("plant", []), steps)
    if reading.report.has_errors:
        raise DiagnosticError(reading.report.diagnostics)
    return Scenario(source.name, program_path, cycle_ms, slaves, steps, list(markers), plants,
                    first_tick_ms)


def read_master(document: Document, report: Reporter, code: str, *, scenario: bool = False
                ) -> tuple[float | None, list[SlaveSpec] | None, float | None]:
    """The ``[master]`` table of a scenario or a properties file (its cycle time and
    slaves; a scenario's also the time to the first 10 ms tick), problems reported with
    ``code``: one reading for both kinds of file."""
    reading = _Reading(document, None, SymbolTable())
    master = document.data.get("master", {})
    cycle_ms = slaves = first_tick_ms = None
    if not isinstance(master, dict):
        reading.error("[master] is a table", ("master",))
        master = {}
    keys = _SCENARIO_MASTER_KEYS if scenario else _MASTER_KEYS
    reading.report.extend(document.unknown_keys(("master",), master, keys, "in [master]"))
    if scenario and "first_tick_ms" in master:
        value = master["first_tick_ms"]
        number = isinstance(value, int | float) and not isinstance(value, bool)
        ms = round(float(value) * 1000) / 1000 if number and math.isfinite(value) else 0.0
        if 0 < ms <= TICK_US / 1000:  # whole microseconds, as all master time
            first_tick_ms = ms
        else:
            reading.error(f"first_tick_ms is a time in milliseconds from 0.001 to "
                          f"{TICK_US / 1000:g}, not {_show(value)}",
                          ("master", "first_tick_ms"), at_value=True)
    if "cycle_ms" in master:
        value = master["cycle_ms"]
        cycle_ms = _cycle(value)
        if cycle_ms is None:
            reading.error(f"cycle_ms is a time in milliseconds from {MIN_CYCLE_MS:g} to "
                          f"{MAX_CYCLE_MS:g}, not {_show(value)}", ("master", "cycle_ms"),
                          at_value=True)
    if "slaves" in master:
        slaves = _slaves(reading, master["slaves"], ("master", "slaves"))
    report.extend(d if d.code != ScenarioCode.INVALID else replace(d, code=code)
                  for d in reading.report.diagnostics)
    return cycle_ms, slaves, first_tick_ms


class _PlantPlace:
    """A ``[[plant]]`` table's place, for ``plant.read_model``'s problems."""

    def __init__(self, reading: _Reading, path: KeyPath) -> None:
        self.reading = reading
        self.path = path

    def problem(self, message: str, key: str | None = None) -> None:
        self.reading.error(message, (*self.path, key) if key else self.path)

    def condition_problem(self, error: ConditionError, key: str) -> None:
        place = self.reading.document.inside((*self.path, key), error.offset, error.length)
        self.reading.report.error(ScenarioCode.CONDITION, error.message, place)

    def operand(self, text: str) -> Operand:
        return parse_operand(text, self.reading.variables, self.reading.symbols)

    def condition(self, text: str) -> Condition:
        return parse_condition(text, self.reading.variables, self.reading.symbols)


def _plants(reading: _Reading, raw: object, steps: list[Step]) -> list[Model]:
    """The ``[[plant]]`` models; a model writing an input another one writes, or that a
    step sets, is an error (at that step's key)."""
    if not isinstance(raw, list) or not all(isinstance(t, dict) for t in raw):
        reading.error("plant models are [[plant]] tables", ("plant",))
        return []
    plant = Plant()
    counts: dict[str, int] = {}
    for index, table in enumerate(raw):
        place = _PlantPlace(reading, ("plant", index))
        kind = str(table.get("type", "plant"))
        counts[kind] = counts.get(kind, 0) + 1
        model = read_model(table, f"{kind}{counts[kind]}", place)
        if model is None:
            continue
        model.line = reading.document.key(("plant", index)).line
        try:
            plant.add(model)
        except ValueError as exc:
            place.problem(str(exc))
    for step in steps:
        for operand, _, line in step.set:
            driver = plant.driver_of(operand)
            if driver is not None:
                written = step.written.get((line, str(operand)), str(operand))
                reading.error(f"'{written}' is driven by the plant model {driver.name}: a "
                              "step cannot set it", reading.set_paths[(line, str(operand))])
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
