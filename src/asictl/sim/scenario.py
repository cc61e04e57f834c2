"""Scenario files: inputs over time, expected outputs, bus changes (TOML).

The schema is a contract (docs/simulation.md). Every problem in a scenario is reported
as a diagnostic at its line in the file: tomllib does not keep positions, so steps are
found by their ``[[step]]`` headers and keys by their text within the step.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Reporter, Severity, Span
from asictl.il import ast
from asictl.il.parser import parse_text
from asictl.sim.operands import Operand, parse_operand
from asictl.source import SourceText, read_source

_DURATION = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*(ms|s|m|min|h)?\s*$", re.IGNORECASE)
_UNIT_MS = {"ms": 1, "s": 1000, "m": 60_000, "min": 60_000, "h": 3_600_000, None: 1000}


def parse_duration(text: str) -> float:
    """'250ms', '10s', '2m', '1h' (a bare number is seconds) -> milliseconds."""
    match = _DURATION.match(text)
    if not match:
        raise ValueError(f"'{text}' is not a duration (examples: 250ms, 10s, 2m, 1h)")
    unit = match[2].lower() if match[2] else None
    return float(match[1]) * _UNIT_MS[unit]


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
    add_slaves: list[SlaveSpec] = field(default_factory=list)
    remove_slaves: list[int] = field(default_factory=list)
    power_fail: bool | None = None
    press_set_button: bool = False


@dataclass
class Scenario:
    file: str
    program: Path | None
    cycle_ms: float | None
    slaves: list[SlaveSpec] | None
    steps: list[Step]

    @property
    def end_ms(self) -> float:
        return max((s.at_ms for s in self.steps), default=0.0)

    def ordered(self) -> list[Step]:
        """Steps by time; at equal times the file's order (sets are applied before checks
        by the engine)."""
        return sorted(self.steps, key=lambda s: s.at_ms)


_STEP_KEYS = {"at_ms", "at", "set", "expect", "add_slaves", "remove_slaves", "power_fail",
              "press_set_button"}


class _Reader:
    def __init__(self, source: SourceText, variables: Mapping[str, int] | None) -> None:
        self.source = source
        self.lines = source.text.split("\n")
        self.report = Reporter()
        self.variables = variables
        self.step_lines = [
            i + 1 for i, line in enumerate(self.lines) if re.match(r"\s*\[\[\s*step\s*\]\]", line)
        ]

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
        for form in (f'"{key}"', f"'{key}'", key):
            line = self.find(form, start, end)
            text = self.lines[line - 1] if 0 < line <= len(self.lines) else ""
            if form in text:
                return line, text.index(form) + 1
        return start, 1


def _slave(reader: _Reader, address: object, spec: object, line: int) -> SlaveSpec | None:
    try:
        number = int(address)  # TOML keys are strings
    except ValueError:
        reader.error(f"slave address '{address}' is not a number", line)
        return None
    if not isinstance(spec, str):
        reader.error(f"slave {number}: expected a string like \"iiio,1\", got {spec!r}", line)
        return None
    module, diagnostics = parse_text(f"[SETUP]\n{number}: {spec}\n", "<slave>")
    setup = module.sections_of(ast.SetupSection)
    if diagnostics or not setup or not setup[0].slaves:
        reader.error(f"slave {number}: '{spec}' is not 'I/O code, ID[, parameter]'", line)
        return None
    slave = setup[0].slaves[0]
    problems = [
        what for what, value in (("I/O code", slave.io_code), ("ID", slave.id_code),
                                 ("parameter", slave.parameter))
        if value is not None and not 0 <= value <= 0xF
    ]
    if not 1 <= number <= 31 or problems:
        reader.error(f"slave {number}: address 1..31 and {', '.join(problems) or 'codes'} "
                     "0..F expected", line)
        return None
    parameter = 0xF if slave.parameter is None else slave.parameter
    return SlaveSpec(number, slave.io_code, slave.id_code, parameter)


def _slaves(reader: _Reader, table: object, line: int, end: int) -> list[SlaveSpec]:
    if not isinstance(table, dict):
        reader.error("slaves are a table: { 16 = \"iiio,1\" }", line)
        return []
    found = []
    for address, spec in table.items():
        slave = _slave(reader, address, spec, reader.key_line(str(address), line, end))
        if slave:
            found.append(slave)
    return found


def _operands(
    reader: _Reader, table: object, what: str, line: int, end: int, *, settable: bool
) -> list[tuple[Operand, int, int]]:
    if not isinstance(table, dict):
        reader.error(f"'{what}' is a table of operands: {{ \"I 4.0\" = 1 }}", line)
        return []
    found = []
    for key, value in table.items():
        at, column = reader.key_at(key, line, end)
        try:
            operand = parse_operand(key, reader.variables)
        except ValueError as exc:
            reader.error(str(exc), at, column)
            continue
        if isinstance(value, bool) or not isinstance(value, int):
            reader.error(f"'{key}': expected a whole number, got {value!r}", at, column)
            continue
        if not 0 <= value <= operand.maximum:
            reader.error(f"'{key}': value {value} out of range 0..{operand.maximum}", at, column)
            continue
        if settable and not operand.settable:
            reader.error(
                f"'{key}' cannot be set: a scenario sets inputs (I, IB) and flags (F, FY)",
                at, column,
            )
            continue
        found.append((operand, value, at))
    return found


def _step(reader: _Reader, index: int, data: object) -> Step | None:
    line = reader.step_lines[index] if index < len(reader.step_lines) else 1
    end = reader.step_lines[index + 1] - 1 if index + 1 < len(reader.step_lines) else len(
        reader.lines
    )
    if not isinstance(data, dict):
        reader.error("a step is a table", line)
        return None
    for unknown in sorted(set(data) - _STEP_KEYS):
        reader.error(f"unknown key '{unknown}' in a step (known: {', '.join(sorted(_STEP_KEYS))})",
                     reader.key_line(unknown, line, end))
    at = data.get("at_ms", data.get("at"))
    if isinstance(at, str):
        try:
            at = parse_duration(at)
        except ValueError as exc:
            reader.error(str(exc), reader.key_line("at", line, end))
            return None
    if isinstance(at, bool) or not isinstance(at, int | float) or at < 0:
        reader.error("each step needs at_ms = <milliseconds, 0 or more>", line)
        return None
    step = Step(float(at), line)
    if "set" in data:
        step.set = _operands(reader, data["set"], "set", reader.key_line("set", line, end), end,
                             settable=True)
    if "expect" in data:
        step.expect = _operands(reader, data["expect"], "expect",
                                reader.key_line("expect", line, end), end, settable=False)
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
    for flag in ("power_fail", "press_set_button"):
        if flag in data:
            if not isinstance(data[flag], bool):
                reader.error(f"{flag} is true or false", reader.key_line(flag, line, end))
            elif flag == "power_fail":
                step.power_fail = data[flag]
            else:
                step.press_set_button = data[flag]
    return step


def read_scenario(source: SourceText, variables: Mapping[str, int] | None = None) -> Scenario:
    """Parse and validate a scenario; ``variables`` (the program's: key name -> size in
    bytes) resolve variable operands.

    Raises ``DiagnosticError`` with every problem found.
    """
    reader = _Reader(source, variables)
    try:
        data = tomllib.loads(source.text)
    except tomllib.TOMLDecodeError as exc:
        where = re.search(r"line (\d+), column (\d+)", str(exc))
        line, column = (int(where[1]), int(where[2])) if where else (1, 1)
        message = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(exc))
        raise DiagnosticError([
            Diagnostic(Severity.ERROR, ScenarioCode.NOT_TOML, f"not valid TOML: {message}",
                       reader.span(line, column))
        ]) from None
    for unknown in sorted(set(data) - {"program", "master", "step"}):
        reader.error(f"unknown key '{unknown}' (known: program, master, step)",
                     reader.key_line(unknown, 1, len(reader.lines)))
    program_path = None
    if "program" in data:
        if isinstance(data["program"], str):
            program_path = Path(source.name).parent / data["program"]
        else:
            reader.error("program is a file name", reader.key_line("program", 1, len(reader.lines)))
    master = data.get("master", {})
    cycle_ms = slaves = None
    master_line = reader.find("[master]", 1, len(reader.lines))
    if not isinstance(master, dict):
        reader.error("[master] is a table", master_line)
        master = {}
    for unknown in sorted(set(master) - {"cycle_ms", "slaves"}):
        reader.error(f"unknown key '{unknown}' in [master] (known: cycle_ms, slaves)",
                     reader.key_line(unknown, master_line, len(reader.lines)))
    if "cycle_ms" in master:
        value = master["cycle_ms"]
        if isinstance(value, bool) or not isinstance(value, int | float) or value <= 0:
            reader.error("cycle_ms is a number of milliseconds above 0",
                         reader.key_line("cycle_ms", master_line, len(reader.lines)))
        else:
            cycle_ms = float(value)
    if "slaves" in master:
        end = reader.step_lines[0] - 1 if reader.step_lines else len(reader.lines)
        slaves = _slaves(reader, master["slaves"],
                         reader.key_line("slaves", master_line, end), end)
    raw_steps = data.get("step", [])
    if not isinstance(raw_steps, list):
        reader.error("steps are [[step]] tables", 1)
        raw_steps = []
    steps = [s for i, d in enumerate(raw_steps) if (s := _step(reader, i, d))]
    if reader.report.has_errors:
        raise DiagnosticError(reader.report.diagnostics)
    return Scenario(source.name, program_path, cycle_ms, slaves, steps)


def load_scenario(path: str | Path, variables: Mapping[str, int] | None = None) -> Scenario:
    return read_scenario(read_source(path), variables)
