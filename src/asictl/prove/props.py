"""Properties files (``NAME.props.toml``): what a program must always, never or
eventually do, and what its environment guarantees.

The file is TOML; its ``program`` line and ``[master]`` table mean what they mean in a
scenario (``sim.scenario.read_master`` reads ``[master]`` for both, so the two cannot
drift). Expressions are written in the scenario's operand names (``I 1.0``,
``QB 16``, ``CV 0``, ``TV 1``, symbols) with ``and or xor not``, parentheses, ``== !=
< <= > >=`` on values (``==`` and ``!=`` also on two conditions), and numbers as
``read_number`` reads them (``12``, ``0x0C``, ``0b1100``). Every mistake is a
diagnostic at its line and column, with a caret.

Nothing here needs z3: a properties file is checked before the prover starts.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

from asictl.codes import ScenarioCode
from asictl.diagnostics import DiagnosticError, Reporter, Span
from asictl.observe.operands import Operand, parse_operand, read_number
from asictl.observe.symbols import SymbolTable
from asictl.readers.tomlfile import Document, KeyPath, read_toml
from asictl.readers.units import UnitError, parse_cycles
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


# ---------------------------------------------------------------------- expressions


@dataclass(frozen=True)
class Ref:
    """An operand, as written."""

    operand: Operand
    text: str


@dataclass(frozen=True)
class Number:
    value: int


@dataclass(frozen=True)
class Truth:
    value: bool


@dataclass(frozen=True)
class Negation:
    arg: Expr


@dataclass(frozen=True)
class Connective:
    op: str  # and, or, xor
    left: Expr
    right: Expr


@dataclass(frozen=True)
class Comparison:
    op: str  # == != < <= > >=
    left: Expr
    right: Expr


Expr = Ref | Number | Truth | Negation | Connective | Comparison


def is_condition(expr: Expr) -> bool:
    """True or false (a bit, a comparison, a combination of them), not a value."""
    if isinstance(expr, Ref):
        return expr.operand.is_bit
    return not isinstance(expr, Number)


def refs(expr: Expr) -> list[Ref]:
    """The operands an expression reads, in order."""
    match expr:
        case Ref():
            return [expr]
        case Number() | Truth():
            return []
        case Negation(arg=arg):
            return refs(arg)
        case Connective(left=left, right=right) | Comparison(left=left, right=right):
            return refs(left) + refs(right)


def show(expr: Expr) -> str:
    """The expression written back (fully parenthesised where it combines)."""
    match expr:
        case Ref(text=text):
            return text
        case Number(value=value):
            return str(value)
        case Truth(value=value):
            return "true" if value else "false"
        case Negation(arg=arg):
            return f"not {show(arg)}"
        case Connective(op=op, left=left, right=right) | Comparison(op=op, left=left, right=right):
            return f"({show(left)} {op} {show(right)})"


_TOKEN = re.compile(r"\s*(?:(?P<paren>[()])|(?P<rel>==|!=|<=|>=|<|>)|(?P<word>[A-Za-z0-9_.]+))")
_KEYWORDS = ("and", "or", "xor", "not", "true", "false")


class _ExprError(Exception):
    def __init__(self, message: str, offset: int) -> None:
        super().__init__(message)
        self.offset = offset


@dataclass
class _Token:
    kind: str  # paren, rel, word, key, end
    text: str
    offset: int


def _tokens(text: str) -> list[_Token]:
    tokens: list[_Token] = []
    pos = 0
    while pos < len(text):
        if not text[pos:].strip():
            break
        match = _TOKEN.match(text, pos)
        if match is None or match.end() == pos:
            start = len(text) - len(text[pos:].lstrip())
            raise _ExprError(f"unexpected character '{text[start]}'", start)
        kind = match.lastgroup or "word"
        value, start = match[kind], match.start(kind)
        if kind == "word" and value.lower() in _KEYWORDS:
            kind = "key"
        tokens.append(_Token(kind, value, start))
        pos = match.end()
    tokens.append(_Token("end", "", len(text)))
    return tokens


class _Parser:
    def __init__(self, text: str, variables: Mapping[str, int] | None,
                 symbols: SymbolTable | None) -> None:
        self.text = text
        self.tokens = _tokens(text)
        self.at = 0
        self.variables = variables
        self.symbols = symbols

    @property
    def token(self) -> _Token:
        return self.tokens[self.at]

    def keyword(self, word: str) -> bool:
        if self.token.kind == "key" and self.token.text.lower() == word:
            self.at += 1
            return True
        return False

    def parse(self) -> Expr:
        expr = self.binary(0)
        if self.token.kind != "end":
            raise _ExprError(f"unexpected '{self.token.text}' (expected and, or, xor or the "
                             "end)", self.token.offset)
        return expr

    _LEVELS = ("or", "xor", "and")

    def binary(self, level: int) -> Expr:
        if level == len(self._LEVELS):
            return self.negation()
        word = self._LEVELS[level]
        start = self.token.offset
        left = self.binary(level + 1)
        while True:
            offset = self.token.offset
            if not self.keyword(word):
                return left
            right = self.binary(level + 1)
            for side, at in ((left, start), (right, offset)):
                if not is_condition(side):
                    raise _ExprError(f"'{word}' combines conditions: compare the value "
                                     f"{show(side)} (such as {show(side)} == 1)", at)
            left = Connective(word, left, right)

    def negation(self) -> Expr:
        offset = self.token.offset
        if self.keyword("not"):
            arg = self.negation()
            if not is_condition(arg):
                raise _ExprError(f"'not' negates a condition, not the value {show(arg)}",
                                 offset)
            return Negation(arg)
        return self.comparison()

    def comparison(self) -> Expr:
        start = self.token.offset
        left = self.atom()
        if self.token.kind != "rel":
            return left
        op, offset = self.token.text, self.token.offset
        self.at += 1
        right = self.atom()
        if op in ("==", "!=") and is_condition(left) and is_condition(right):
            pass  # two conditions: equal (the same truth) or not
        else:
            for side in (left, right):
                if isinstance(side, Truth | Negation | Connective | Comparison):
                    raise _ExprError(f"'{op}' compares values (operands and numbers), not "
                                     f"{show(side)}",
                                     start if side is left else offset + len(op))
        if self.token.kind == "rel":
            raise _ExprError("comparisons do not chain: combine them with 'and'",
                             self.token.offset)
        return Comparison(op, left, right)

    def atom(self) -> Expr:
        token = self.token
        if token.kind == "paren" and token.text == "(":
            self.at += 1
            inner = self.binary(0)
            if not (self.token.kind == "paren" and self.token.text == ")"):
                raise _ExprError("expected ')'", self.token.offset)
            self.at += 1
            return inner
        if token.kind == "key" and token.text.lower() in ("true", "false"):
            self.at += 1
            return Truth(token.text.lower() == "true")
        if token.kind != "word":
            what = "the end" if token.kind == "end" else f"'{token.text}'"
            raise _ExprError(f"expected an operand, a number or '(', found {what}",
                             token.offset)
        words = []
        while self.token.kind == "word":
            words.append(self.token)
            self.at += 1
        written = self.text[words[0].offset:words[-1].offset + len(words[-1].text)]
        if len(words) == 1 and words[0].text[:1].isdigit() and "." not in words[0].text:
            try:
                return Number(read_number(written))
            except ValueError as exc:
                raise _ExprError(str(exc), token.offset) from None
        try:
            operand = parse_operand(written, self.variables, self.symbols)
        except ValueError as exc:
            raise _ExprError(str(exc), token.offset) from None
        return Ref(operand, written)


def parse_expression(text: str, variables: Mapping[str, int] | None = None,
                     symbols: SymbolTable | None = None) -> Expr:
    """An expression; ``ValueError`` whose ``args[1]`` is the offset of the mistake."""
    try:
        return _Parser(text, variables, symbols).parse()
    except _ExprError as exc:
        raise ValueError(str(exc), exc.offset) from None


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
) -> Properties:
    """Parse and check a properties file; ``DiagnosticError`` with every mistake."""
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
    cycle_ms, slaves = read_master(document, reading.report, ScenarioCode.PROPERTIES)

    def expression(value: object, path: KeyPath, condition: bool = True) -> Expr | None:
        key = next(str(p) for p in reversed(path) if isinstance(p, str))
        if not isinstance(value, str):
            reading.error(f"{key} is an expression in quotes, such as \"Q 2.0 and not I 1.2\"",
                          path)
            return None
        start = document.inside(path)
        line, column = start.line, start.column
        try:
            expr = parse_expression(value, variables, symbols)
        except ValueError as exc:
            offset = exc.args[1] if len(exc.args) > 1 else 0
            reading.report.error(ScenarioCode.PROPERTIES, str(exc.args[0]),
                                 Span(source.name, line, column + offset))
            return None
        if condition and not is_condition(expr):
            reading.report.error(ScenarioCode.PROPERTIES,
                                 f"{key} is a condition, not the value {show(expr)} (compare "
                                 f"it: {show(expr)} == 1)", Span(source.name, line, column))
            return None
        return expr

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
    if reading.report.has_errors:
        raise DiagnosticError(reading.report.diagnostics)
    return Properties(source.name, program_path, cycle_ms, slaves, assume, properties)


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
