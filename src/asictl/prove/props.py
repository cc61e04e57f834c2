"""Properties files (``NAME.props.toml``): what a program must always, never or
eventually do, and what its environment guarantees.

The file is TOML; its ``program`` line and ``[master]`` table mean what they mean in a
scenario (and the ``[master]`` table is read by the scenario reader itself, so the two
cannot drift). Properties and ``[assume]`` are conditions (``observe/condition.py``,
docs/conditions.md), over the program's operands and symbols. Every mistake is a
diagnostic at its line and column, with a caret; one inside a condition points at the
offending token inside the string (E410).

Nothing here needs z3: a properties file is checked before the prover starts.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Reporter, Severity, Span
from asictl.il.suggest import did_you_mean
from asictl.observe.condition import ConditionError, Expr, parse_expression, show
from asictl.observe.symbols import SymbolTable
from asictl.readers.strings import string_column
from asictl.sim.scenario import SlaveSpec, parse_duration, read_scenario
from asictl.source import SourceText, from_string

SUFFIX = ".props.toml"
_TOP_KEYS = ("program", "master", "assume", "property")
_ASSUME_KEYS = ("always",)
_PROPERTY_KEYS = ("name", "never", "always", "reachable", "when", "then", "within")
_WITHIN = re.compile(r"^\s*(\d+)\s*cycles?\s*$", re.IGNORECASE)


class Kind(StrEnum):
    NEVER = "never"
    ALWAYS = "always"
    REACHABLE = "reachable"
    RESPONSE = "when"


# ---------------------------------------------------------------------- the file


@dataclass(frozen=True)
class Property:
    name: str
    kind: Kind
    #: the condition: what must never / always hold, what is reached, the trigger
    expr: Expr
    line: int
    #: for when/then: the response and how soon (cycles, or milliseconds)
    then: Expr | None = None
    within_cycles: int | None = None
    within_ms: float | None = None

    @property
    def slug(self) -> str:
        """The name as a file name part: ``never both directions`` -> ``never-both-directions``."""
        slug = re.sub(r"[^a-z0-9]+", "-", self.name.lower()).strip("-")
        return slug or "property"

    def text(self) -> str:
        """The property as the file says it."""
        if self.kind is Kind.RESPONSE:
            assert self.then is not None
            within = (f"{self.within_cycles} cycles" if self.within_cycles is not None
                      else f"{self.within_ms:g} ms")
            return f"when {show(self.expr)} then {show(self.then)} within {within}"
        return f"{self.kind.value} {show(self.expr)}"


@dataclass
class Properties:
    file: str
    program: Path | None
    cycle_ms: float | None
    slaves: list[SlaveSpec] | None
    assume: list[Expr]
    properties: list[Property]


class _Reader:
    def __init__(self, source: SourceText) -> None:
        self.source = source
        self.lines = source.text.split("\n")
        self.report = Reporter()
        self.property_lines = [i + 1 for i, line in enumerate(self.lines)
                               if re.match(r"\s*\[\[\s*property\s*\]\]", line)]

    def error(self, message: str, line: int, column: int = 1) -> None:
        self.report.error(ScenarioCode.PROPERTIES, message, Span(self.source.name, line, column))

    def section(self, name: str) -> tuple[int, int]:
        """The lines of a ``[name]`` table: from its header to the next header."""
        start = next((i + 1 for i, line in enumerate(self.lines)
                      if re.match(rf"\s*\[\s*{name}\s*\]", line)), 1)
        return start, self.next_header(start)

    def next_header(self, start: int) -> int:
        for number in range(start + 1, len(self.lines) + 1):
            if re.match(r"\s*\[", self.lines[number - 1]):
                return number - 1
        return len(self.lines)

    def key_at(self, key: str, start: int, end: int) -> tuple[int, int]:
        """Line and column of ``key =`` between two lines, else the first of them."""
        bare = re.compile(rf"(?:^|[\s{{,])(?P<key>{re.escape(key)}|\"{re.escape(key)}\")\s*=")
        for number in range(start, min(end, len(self.lines)) + 1):
            found = bare.search(self.lines[number - 1])
            if found:
                return number, found.start("key") + 1
        return start, 1

    def value_at(self, key: str, start: int, end: int, nth: int = 0) -> tuple[int, int]:
        """Where the text of a key's string value starts (the ``nth`` string of a list,
        which may run over several lines)."""
        line, column = self.key_at(key, start, end)
        first = self.lines[line - 1] if 0 < line <= len(self.lines) else ""
        pos = first.find("=", column - 1) + 1
        count = 0
        for number in range(line, min(max(end, line), len(self.lines)) + 1):
            text = self.lines[number - 1]
            while True:
                quotes = [i for i in (text.find('"', pos), text.find("'", pos)) if i >= 0]
                if not quotes:
                    break
                quote = min(quotes)
                if count == nth:
                    return number, quote + 2
                count += 1
                close = text.find(text[quote], quote + 1)
                if close < 0:
                    break
                pos = close + 1
            pos = 0
        return line, column

    def unknown(self, table: Mapping[str, object], known: tuple[str, ...], where: str,
                start: int, end: int) -> None:
        for name in sorted(set(table) - set(known)):
            line, column = self.key_at(name, start, end)
            self.error(f"unknown key '{name}'{where}{did_you_mean(name, list(known))} "
                       f"(known: {', '.join(known)})", line, column)


def _master(reader: _Reader, source: SourceText) -> tuple[float | None, list[SlaveSpec] | None]:
    """The ``[master]`` table, read by the scenario reader at its own lines."""
    start, end = reader.section("master")
    if not any(re.match(r"\s*\[\s*master\s*\]", line) for line in reader.lines):
        return None, None
    kept = [line if start <= number <= end else ""
            for number, line in enumerate(reader.lines, 1)]
    try:
        scenario = read_scenario(from_string(source.name, "\n".join(kept)))
    except DiagnosticError as exc:
        reader.report.diagnostics.extend(exc.diagnostics)
        return None, None
    return scenario.cycle_ms, scenario.slaves


def read_properties(
    source: SourceText,
    variables: Mapping[str, int] | None = None,
    symbols: SymbolTable | None = None,
) -> Properties:
    """Parse and check a properties file; ``DiagnosticError`` with every mistake."""
    reader = _Reader(source)
    try:
        data = tomllib.loads(source.text)
    except tomllib.TOMLDecodeError as exc:
        where = re.search(r"line (\d+), column (\d+)", str(exc))
        line, column = (int(where[1]), int(where[2])) if where else (1, 1)
        message = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(exc))
        raise DiagnosticError([Diagnostic(Severity.ERROR, ScenarioCode.PROPERTIES,
                                          f"not valid TOML: {message}",
                                          Span(source.name, line, column))]) from None
    except RecursionError:  # tomllib recurses per nested array or inline table
        raise DiagnosticError([Diagnostic(Severity.ERROR, ScenarioCode.PROPERTIES,
                                          "not valid TOML: nested too deeply",
                                          Span(source.name, 1, 1))]) from None
    reader.unknown(data, _TOP_KEYS, "", 1, len(reader.lines))
    program = data.get("program")
    program_path = None
    if program is not None:
        if isinstance(program, str) and program and "\0" not in program:
            program_path = Path(source.name).parent / program
        else:
            reader.error("program is a file name", *reader.key_at("program", 1, len(reader.lines)))
    cycle_ms, slaves = _master(reader, source)

    def expression(value: object, key: str, start: int, end: int, nth: int = 0) -> Expr | None:
        line, column = reader.value_at(key, start, end, nth)
        if not isinstance(value, str):
            reader.error(f"{key} is an expression in quotes, such as \"Q 2.0 and not I 1.2\"",
                         *reader.key_at(key, start, end))
            return None
        try:
            return parse_expression(value, variables, symbols)
        except ConditionError as exc:
            text = reader.lines[line - 1] if 0 < line <= len(reader.lines) else ""
            at = string_column(text, column - 2, exc.offset) if column >= 2 else column
            reader.report.error(ScenarioCode.CONDITION, exc.message,
                                Span(source.name, line, at, exc.length))
            return None

    assume: list[Expr] = []
    table = data.get("assume", {})
    start, end = reader.section("assume")
    if not isinstance(table, dict):
        reader.error("[assume] is a table: always = [\"not (I 1.0 and I 1.1)\"]", start)
        table = {}
    reader.unknown(table, _ASSUME_KEYS, " in [assume]", start, end)
    always = table.get("always", [])
    for index, text in enumerate(always if isinstance(always, list) else [always]):
        expr = expression(text, "always", start, end, index)
        if expr is not None:
            assume.append(expr)

    properties: list[Property] = []
    raw = data.get("property", [])
    if not isinstance(raw, list):
        reader.error("properties are [[property]] tables", 1)
        raw = []
    names: set[str] = set()
    for index, entry in enumerate(raw):
        start = reader.property_lines[index] if index < len(reader.property_lines) else 1
        end = reader.next_header(start)
        if not isinstance(entry, dict):
            reader.error("a property is a table", start)
            continue
        found = _property(reader, entry, start, end, expression, names)
        if found is not None:
            properties.append(found)
    if reader.report.has_errors:
        raise DiagnosticError(reader.report.diagnostics)
    return Properties(source.name, program_path, cycle_ms, slaves, assume, properties)


def _property(reader: _Reader, entry: dict[str, object], start: int, end: int,
              expression: object, names: set[str]) -> Property | None:
    assert callable(expression)
    reader.unknown(entry, _PROPERTY_KEYS, " in [[property]]", start, end)
    name = entry.get("name")
    if not isinstance(name, str) or not name.strip():
        reader.error('a property needs a name = "..."', *reader.key_at("name", start, end))
        return None
    if name in names:
        reader.error(f"two properties are named '{name}'", *reader.key_at("name", start, end))
        return None
    names.add(name)
    kinds = [k for k in ("never", "always", "reachable", "when") if k in entry]
    if len(kinds) != 1:
        reader.error(f"property '{name}' needs exactly one of never, always, reachable or "
                     "when (with then and within)", start)
        return None
    kind = Kind(kinds[0])
    expr = expression(entry[kind.value], kind.value, start, end)
    if kind is not Kind.RESPONSE:
        for extra in ("then", "within"):
            if extra in entry:
                reader.error(f"'{extra}' belongs to a when/then property",
                             *reader.key_at(extra, start, end))
                return None
        return Property(name, kind, expr, start) if expr is not None else None
    if "then" not in entry or "within" not in entry:
        reader.error(f"property '{name}': when needs then and within (\"3 cycles\" or "
                     "\"50ms\")", start)
        return None
    then = expression(entry["then"], "then", start, end)
    within = entry["within"]
    cycles = ms = None
    if isinstance(within, int) and not isinstance(within, bool) and 0 <= within <= 10_000:
        cycles = within
    elif isinstance(within, str) and (match := _WITHIN.match(within)):
        cycles = int(match[1])
    elif isinstance(within, str):
        try:
            ms = parse_duration(within)
        except ValueError:
            ms = None
    if (cycles is None and ms is None) or (cycles is not None and cycles > 10_000):
        reader.error('within is "N cycles" (0..10000) or a time such as "50ms"',
                     *reader.value_at("within", start, end))
        return None
    if expr is None or then is None:
        return None
    return Property(name, kind, expr, start, then, cycles, ms)


def properties_for(program: Path) -> Path:
    """``NAME.props.toml`` beside ``NAME.asi``."""
    return program.with_name(program.stem + SUFFIX)


def program_for(properties: Path) -> Path:
    name = properties.name
    stem = name[: -len(SUFFIX)] if name.endswith(SUFFIX) else properties.stem
    return properties.with_name(stem + ".asi")
