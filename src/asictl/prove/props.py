"""Properties files (``NAME.props.toml``): what a program must always, never or
eventually do, and what its environment guarantees.

The file is TOML; its ``program`` line and ``[master]`` table mean what they mean in a
scenario (``sim.scenario.read_master`` reads ``[master]`` for both, so the two cannot
drift). Properties and ``[assume]`` are conditions (``observe/condition.py``,
docs/conditions.md), over the program's operands and symbols. Every mistake is a
diagnostic at its line and column, with a caret; one inside a condition points at the
offending token inside the string (E410).

Nothing here needs z3: a properties file is checked before the prover starts.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path

from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Reporter
from asictl.observe.condition import ConditionError, Expr, parse_expression, refs, show
from asictl.observe.symbols import SymbolTable
from asictl.prove.scope import Scope
from asictl.readers.tomlfile import Document, KeyPath, read_toml
from asictl.readers.units import UnitError, format_duration, parse_cycles
from asictl.sim.scenario import SlaveSpec, read_master
from asictl.source import SourceText

SUFFIX = ".props.toml"
_TOP_KEYS = ("program", "master", "assume", "property")
_ASSUME_KEYS = ("always",)
_PROPERTY_KEYS = ("name", "never", "always", "reachable", "when", "then", "within")


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
        """The name as a file name part, unique per name and the same in every run:
        ``never both directions`` -> ``never-both-directions``. A name the plain form
        cannot be read back from (capitals, punctuation, letters outside ASCII:
        ``Tür zu``, ``a.b`` beside ``a-b``) gets the first ten hex digits of its
        SHA-256 as well (``t-r-zu-5d1c...``), so no two names share a file."""
        slug = re.sub(r"[^a-z0-9]+", "-", self.name.lower()).strip("-")
        if slug and self.name == slug.replace("-", " "):
            return slug
        digest = hashlib.sha256(self.name.encode("utf-8", "surrogatepass")).hexdigest()[:10]
        return f"{slug or 'property'}-{digest}"

    def text(self) -> str:
        """The property as the file says it."""
        if self.kind is Kind.RESPONSE:
            assert self.then is not None and (self.within_cycles, self.within_ms) != (None, None)
            within = (f"{self.within_cycles} cycles" if self.within_cycles is not None
                      else format_duration(self.within_ms or 0.0))
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
    #: what is suspicious but not wrong (W431), to be shown with the verdicts
    warnings: list[Diagnostic] = field(default_factory=list)
    #: the program's symbol table, to name operands in notes and scenarios
    symbols: SymbolTable = field(default_factory=SymbolTable)


@dataclass
class _Reading:
    """A properties file being read: its document and what is wrong so far."""

    document: Document
    report: Reporter

    def error(self, message: str, path: KeyPath, *, at_value: bool = False) -> None:
        self.report.diagnostics.append(
            self.document.error(ScenarioCode.PROPERTIES, message, path, at_value=at_value))


def read_properties(
    source: SourceText,
    variables: Mapping[str, int] | None = None,
    symbols: SymbolTable | None = None,
    scope: Scope | None = None,
) -> Properties:
    """Parse and check a properties file; ``DiagnosticError`` with every mistake.
    With the program's ``scope``, every operand must exist on its bus and in it (E430),
    and a never/always property the program cannot change is warned of (W431)."""
    document = read_toml(source.name, source.text)
    data = document.data
    reading = _Reading(document, Reporter())
    reading.report.extend(document.unknown_keys((), data, _TOP_KEYS))
    program = data.get("program")
    program_path = None
    if program is not None:
        if isinstance(program, str) and program and "\0" not in program:
            program_path = Path(source.name).parent / program
        else:
            reading.error("program is a file name", ("program",))
    cycle_ms, slaves, _ = read_master(document, reading.report, ScenarioCode.PROPERTIES)
    bus = None if slaves is None else [spec.address for spec in slaves]

    def expression(value: object, path: KeyPath) -> Expr | None:
        key = next(str(p) for p in reversed(path) if isinstance(p, str))
        if not isinstance(value, str):
            reading.error(f"{key} is an expression in quotes, such as \"Q 2.0 and not I 1.2\"",
                          path)
            return None
        try:
            expr = parse_expression(value, variables, symbols)
        except ConditionError as exc:
            reading.report.error(ScenarioCode.CONDITION, exc.message,
                                 document.inside(path, exc.offset, exc.length))
            return None
        wrong = False
        for ref in refs(expr) if scope is not None else ():
            problem = scope.problem(ref.operand, bus) if scope is not None else None
            if problem is not None:
                reading.report.error(ScenarioCode.NO_SUCH_OPERAND, problem,
                                     document.inside(path, ref.offset, len(ref.text)))
                wrong = True
        return None if wrong else expr

    assume: list[Expr] = []
    table = data.get("assume", {})
    if not isinstance(table, dict):
        reading.error("[assume] is a table: always = [\"not (I 1.0 and I 1.1)\"]", ("assume",))
        table = {}
    reading.report.extend(document.unknown_keys(("assume",), table, _ASSUME_KEYS,
                                                "in [assume]"))
    always = table.get("always", [])
    for index, text in enumerate(always if isinstance(always, list) else [always]):
        path: KeyPath = ("assume", "always", index) if isinstance(always, list) \
            else ("assume", "always")
        expr = expression(text, path)
        if expr is not None:
            assume.append(expr)

    properties: list[Property] = []
    raw = data.get("property", [])
    if not isinstance(raw, list):
        reading.error("properties are [[property]] tables", ("property",))
        raw = []
    names: set[str] = set()
    for index, entry in enumerate(raw):
        if not isinstance(entry, dict):
            reading.error("a property is a table", ("property", index))
            continue
        found = _property(reading, ("property", index), entry, expression, names)
        if found is not None:
            properties.append(found)
            if scope is not None:
                _environment_only(reading, ("property", index), found, scope)
    if reading.report.has_errors:
        raise DiagnosticError(reading.report.diagnostics)
    return Properties(source.name, program_path, cycle_ms, slaves, assume, properties,
                      reading.report.diagnostics, symbols or SymbolTable())


def _environment_only(reading: _Reading, path: KeyPath, prop: Property, scope: Scope) -> None:
    """W431: a never/always property over inputs (or host-written flags) alone, which no
    line of the program writes: its verdict says nothing about the program."""
    if prop.kind not in (Kind.NEVER, Kind.ALWAYS):
        return
    found = list(refs(prop.expr))
    if found and all(scope.environment(ref.operand) for ref in found):
        first = found[0]
        names = ", ".join(dict.fromkeys(ref.text for ref in found))
        reading.report.warning(
            ScenarioCode.ENVIRONMENT_ONLY,
            f"property '{prop.name}' is decided by the environment alone: the program "
            f"writes none of {names}",
            reading.document.inside((*path, prop.kind.value), first.offset, len(first.text)))


def _property(reading: _Reading, path: KeyPath, entry: dict[str, object],
              expression: object, names: set[str]) -> Property | None:
    assert callable(expression)
    reading.report.extend(reading.document.unknown_keys(path, entry, _PROPERTY_KEYS,
                                                        "in [[property]]"))
    start = reading.document.key(path).line
    name = entry.get("name")
    if not isinstance(name, str) or not name.strip():
        reading.error('a property needs a name = "..."', (*path, "name"))
        return None
    if name in names:
        reading.error(f"two properties are named '{name}'", (*path, "name"))
        return None
    names.add(name)
    kinds = [k for k in ("never", "always", "reachable", "when") if k in entry]
    if len(kinds) != 1:
        reading.error(f"property '{name}' needs exactly one of never, always, reachable or "
                      "when (with then and within)", path)
        return None
    kind = Kind(kinds[0])
    expr = expression(entry[kind.value], (*path, kind.value))
    if kind is not Kind.RESPONSE:
        for extra in ("then", "within"):
            if extra in entry:
                reading.error(f"'{extra}' belongs to a when/then property", (*path, extra))
                return None
        return Property(name, kind, expr, start) if expr is not None else None
    if "then" not in entry or "within" not in entry:
        reading.error(f"property '{name}': when needs then and within (\"3 cycles\" or "
                      "\"50ms\")", path)
        return None
    then = expression(entry["then"], (*path, "then"))
    try:
        cycles, ms = _within(entry["within"])
    except UnitError as exc:
        reading.error(f"within: {exc}", (*path, "within"), at_value=True)
        return None
    if expr is None or then is None:
        return None
    return Property(name, kind, expr, start, then, cycles, ms)


def _within(value: object) -> tuple[int | None, float | None]:
    """A response's bound: ``"3 cycles"`` (0..10000) or a time with its unit
    (``readers.units.parse_cycles``); a bare number could be either, and is refused with
    both readings."""
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise UnitError('"N cycles" (0..10000) or a time such as "50ms"')
    text = str(value).strip()
    if not isinstance(value, str) or text.isdigit():
        raise UnitError(f"give a unit: \"{text} cycles\" or \"{text}ms\"")
    found = parse_cycles(text)
    if found.count is not None and found.count > 10_000:
        raise UnitError("at most 10000 cycles")
    return found.count, found.ms


def properties_for(program: Path) -> Path:
    """``NAME.props.toml`` beside ``NAME.asi``."""
    return program.with_name(program.stem + SUFFIX)


def program_for(properties: Path) -> Path:
    name = properties.name
    stem = name[: -len(SUFFIX)] if name.endswith(SUFFIX) else properties.stem
    return properties.with_name(stem + ".asi")
