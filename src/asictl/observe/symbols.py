"""Symbol tables: names for a program's operands, kept beside it (``PROG.symbols.toml``).

An IL source names operands by address only (``I 1.0``, ``C 0``); the people who debug
it think in names (``Start``, ``Parts``). A symbol table gives the names without
touching the source::

    Start = "I 1.0"
    Motor = "Q 2.0"
    Parts = "C 0"

Scenarios may then write ``set = { Start = 1 }`` and ``expect = { "CV Parts" = 3 }``,
traces and plots name their lanes by symbol, and the debugger prints and sets by
symbol. One module serves all of them (and any later tool that shows operands).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError
from asictl.il.ast import key
from asictl.readers.tomlfile import read_toml
from asictl.source import SYMBOLS_SUFFIX, SourceText, read_source, symbols_path

SUFFIX = SYMBOLS_SUFFIX
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
#: ``CV Parts``, ``TV Delay``: a counter's value, a timer's remaining time, by name
_VALUE_OF = re.compile(r"^\s*(CV|TV)\s+([A-Za-z_][A-Za-z0-9_]*)\s*$", re.IGNORECASE)


@dataclass(frozen=True)
class SymbolTable:
    """Names -> operand texts (as the operand prints, e.g. ``"I 1.0"``), and back."""

    file: str = ""
    #: key(name) -> (name as written, operand text)
    entries: Mapping[str, tuple[str, str]] = field(default_factory=dict)

    def __bool__(self) -> bool:
        return bool(self.entries)

    def __len__(self) -> int:
        return len(self.entries)

    def operand(self, name: str) -> str | None:
        """The operand a name stands for, or None."""
        entry = self.entries.get(key(name.strip()))
        return entry[1] if entry else None

    def name_of(self, operand: str) -> str | None:
        """The name of an operand (its printed form), if it has one."""
        for name, text in self.entries.values():
            if text == operand:
                return name
        return None

    def resolve(self, text: str) -> str:
        """``Start`` -> ``I 1.0``, ``CV Parts`` -> ``CV 0``; anything else unchanged."""
        direct = self.operand(text)
        if direct is not None:
            return direct
        match = _VALUE_OF.match(text)
        if match:
            target = self.operand(match[2])
            if target is not None:
                number = target.split()[-1]
                return f"{match[1].upper()} {number}"
        return text

    def label(self, operand: str) -> str:
        """How a trace names an operand's lane: its symbol, else the operand itself.
        ``CV 0`` of a counter named ``Parts`` is ``CV Parts``."""
        name = self.name_of(operand)
        if name is not None:
            return name
        match = re.match(r"^(CV|TV) (\d+)$", operand)
        if match:
            kind = "C" if match[1] == "CV" else "T"
            named = self.name_of(f"{kind} {match[2]}")
            if named is not None:
                return f"{match[1]} {named}"
        return operand


def read_symbols(
    source: SourceText, check: Callable[[str], str] | None = None
) -> SymbolTable:
    """Parse a symbol table; ``check(text)`` returns an operand's printed form or raises
    ``ValueError`` (the scenario reader's operand parser). Raises ``DiagnosticError``."""
    document = read_toml(source.name, source.text)
    problems: list[Diagnostic] = []

    def error(message: str, name: str) -> None:
        problems.append(document.error(ScenarioCode.SYMBOLS, message, (name,)))

    data = document.data
    entries: dict[str, tuple[str, str]] = {}
    for name, value in data.items():
        if not _NAME.fullmatch(name):
            error(f"symbol '{name}': a name is a letter or _ followed by letters, digits, _",
                  name)
            continue
        if not isinstance(value, str):
            error(f"symbol '{name}': the operand is a string like \"I 1.0\"", name)
            continue
        text = value
        if check is not None:
            try:
                text = check(value)
            except ValueError as exc:
                error(f"symbol '{name}': {exc}", name)
                continue
            try:
                check(name)
            except ValueError:
                pass
            else:
                error(f"symbol '{name}' reads as an operand itself; choose another name", name)
                continue
        if key(name) in entries:
            error(f"symbol '{name}' is defined twice (names ignore case)", name)
            continue
        entries[key(name)] = (name, text)
    if problems:
        raise DiagnosticError(problems)
    return SymbolTable(source.name, entries)


def load_symbols(
    path: str | Path, check: Callable[[str], str] | None = None
) -> SymbolTable:
    return read_symbols(read_source(path), check)


def symbols_for(
    program: str | Path | None, check: Callable[[str], str] | None = None
) -> SymbolTable:
    """The table beside a program, or an empty one when there is none."""
    if program is None or str(program) == "-":
        return SymbolTable()
    path = symbols_path(program)
    return load_symbols(path, check) if path.is_file() else SymbolTable()
