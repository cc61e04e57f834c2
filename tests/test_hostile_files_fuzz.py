"""Hostile files, generated: properties, scenarios with a plant model, inventories, watch
tables and symbol tables, each a valid file with bytes cut out, repeated or slipped in
(brackets, quotes, deep nesting, long runs, control characters). Every reader answers
with the file as read or with diagnostics that render (exit 2 at the command line),
never another exception (exit 3) and never a hang: hypothesis's deadline bounds each.
Sized for CI; ``-m slow`` runs many more examples."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from asictl.diagnostics import DiagnosticError, render_text
from asictl.errors import UserError
from asictl.fleet.inventory import read_inventory
from asictl.host.watch import read_table
from asictl.observe.operands import parse_operand
from asictl.observe.symbols import read_symbols
from asictl.prove.props import read_properties
from asictl.sim.scenario import read_scenario
from asictl.source import SourceText, from_string

DEMOS = Path(__file__).resolve().parents[1] / "demos"

SYMBOLS = '''Start = "I 4.0"
Motor = "Q 17.3"
Count = "FY 10"
'''
WATCH = '''watch = ["F 10.0", "I 4.0 and not Q 17.3", "Motor"]
'''

#: Each kind of file: a valid one to start from, and its reader.
KINDS: dict[str, tuple[str, Callable[[SourceText], object]]] = {
    "properties": ((DEMOS / "blink.props.toml").read_text(), read_properties),
    "scenario and plant": ((DEMOS / "sequence.scenario.toml").read_text(), read_scenario),
    "inventory": ((DEMOS / "plant.toml").read_text(), read_inventory),
    "watch table": (WATCH, read_table),
    "symbol table": (SYMBOLS, lambda source: read_symbols(
        source, lambda text: str(parse_operand(text)))),
}

PIECES = st.sampled_from([
    "[", "]", "[[", "]]", "{", "}", "=", '"', "'", "'''", '"""', ",", ".", "\n", "#",
    "(" * 200, ")" * 200, " and I 4.0" * 300, "not " * 200, "9" * 400, "-", "1e999",
    "ms", "s", "h", "16ms", "0x", "I 4.0", "Q 17.3", "F 10.0", "T 0", "\\", "\\u0000",
    "\x00", "\x1b[2J", "\x07", "\r", "\t", "é", "\ufeff", "[masters.x]", "[[step]]",
    "[plant.x]", "kind = ", "true", "inf", "nan", "2024-01-01",
])


@st.composite
def hostile(draw: st.DrawFn, text: str) -> str:
    """``text`` with up to 4 edits: a slice cut, a slice repeated, pieces slipped in."""
    for _ in range(draw(st.integers(1, 4))):
        start = draw(st.integers(0, len(text)))
        end = draw(st.integers(start, min(len(text), start + 80)))
        edit = draw(st.sampled_from(["cut", "repeat", "insert"]))
        if edit == "cut":
            text = text[:start] + text[end:]
        elif edit == "repeat":
            text = text[:end] + text[start:end] * draw(st.integers(2, 50)) + text[end:]
        else:
            text = text[:start] + "".join(draw(st.lists(PIECES, max_size=6))) + text[start:]
    return text


def answers_plainly(kind: str, text: str) -> None:
    _, reader = KINDS[kind]
    source = from_string(f"hostile-{kind.replace(' ', '-')}.toml", text)
    try:
        reader(source)
    except DiagnosticError as exc:
        assert exc.diagnostics
        assert render_text(exc.diagnostics, {source.name: source.text})
    except UserError as exc:
        assert str(exc)


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_the_valid_file_each_starts_from_is_read(kind):
    text, reader = KINDS[kind]
    if kind == "properties":  # its operands are the program's, here without it
        return answers_plainly(kind, text)
    assert reader(from_string("valid.toml", text)) is not None


@pytest.mark.parametrize("kind", sorted(KINDS))
@settings(max_examples=40, deadline=5000, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_a_hostile_file_is_read_or_refused_plainly(kind, data):
    answers_plainly(kind, data.draw(hostile(KINDS[kind][0])))


@pytest.mark.slow
@pytest.mark.parametrize("kind", sorted(KINDS))
@settings(max_examples=2000, deadline=5000, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_a_hostile_file_is_read_or_refused_plainly_long_run(kind, data):
    answers_plainly(kind, data.draw(hostile(KINDS[kind][0])))


def test_an_invalid_escape_in_a_string_is_a_diagnostic():
    """Found by the test above: the reader placing the error re-read the string and let
    tomllib's own exception out (exit 3)."""
    with pytest.raises(DiagnosticError):
        read_table(from_string("w.watch.toml", 'watch = ["\\F 10.0"]\n'))
