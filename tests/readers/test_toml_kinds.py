"""Every TOML file asictl reads reports a mistake in one form: the same syntax error, the
same nesting, the same unknown key read the same (message, code, line and column) in a
scenario, a symbol table, a properties file, an inventory and a watch table."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from asictl.diagnostics import DiagnosticError
from asictl.fleet.inventory import read_inventory
from asictl.host.watch import read_table
from asictl.observe.symbols import read_symbols
from asictl.prove.props import read_properties
from asictl.sim.scenario import read_scenario
from asictl.source import SourceText, from_string

READERS: dict[str, Callable[[SourceText], object]] = {
    "scenario": read_scenario,
    "symbols": read_symbols,
    "properties": read_properties,
    "inventory": read_inventory,
    "watch": read_table,
}


def _all(read: Callable[[SourceText], object], text: str) -> list[str]:
    with pytest.raises(DiagnosticError) as caught:
        read(from_string("f.toml", text))
    return [f"{d.span}: {d.message} [{d.code}]" for d in caught.value.diagnostics]


@pytest.mark.parametrize("kind", READERS)
@pytest.mark.parametrize(("text", "expected"), [
    ('# a file\nx = [1,\n  2 3]\n', "f.toml:3:5: not valid TOML: unclosed array [E400]"),
    ('x = "open\n', "f.toml:1:10: not valid TOML: illegal character '\\n' [E400]"),
    ("[t]\n[t]\n", "f.toml:2:3: not valid TOML: cannot declare ('t',) twice [E400]"),
    ("x = " + "[" * 1000 + "]" * 1000, "f.toml:1:37: not valid TOML: arrays or tables nested "
     "more than 32 deep [E400]"),
])
def test_a_syntax_error_reads_the_same_in_every_kind(kind: str, text: str, expected: str
                                                     ) -> None:
    assert _all(READERS[kind], text) == [expected]


#: An unknown top-level key and what each kind knows (a symbol table's keys are its
#: names, so any name is known there).
KNOWN = {
    "scenario": "markers, master, plant, program, step",
    "properties": "assume, master, program, property",
    "inventory": "defaults, masters",
    "watch": "watch",
}


@pytest.mark.parametrize("kind", KNOWN)
def test_an_unknown_key_reads_the_same_in_every_kind(kind: str) -> None:
    text = '# mine\n  mastrs = 1\n'
    hint = {"scenario": "master", "properties": "master", "inventory": "masters"}.get(kind)
    suggestion = f"; did you mean '{hint}'?" if hint else ""
    found = _all(READERS[kind], text)
    assert (f"f.toml:2:3: unknown key 'mastrs'{suggestion} (known: {KNOWN[kind]}) "
            "[E407]") in found
