"""The TOML reader: values from tomllib, the place of every key and value, one form of
syntax error.

The place test writes generated documents in every form TOML allows for a table (a
``[header]``, an inline table, dotted keys, ``[[arrays of tables]]``), noting where the
writer itself put each key and value, and asks the reader to find the same places.
"""

from __future__ import annotations

import random
import tomllib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from asictl.diagnostics import DiagnosticError
from asictl.readers.tomlfile import MAX_NESTING, KeyPath, read_toml, toml_key, toml_string

# --------------------------------------------------------------------- a writer


class _Writer:
    """Writes a document, noting each key's and value's (line, column) as it goes."""

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng
        self.text = ""
        self.keys: dict[KeyPath, tuple[int, int]] = {}
        self.values: dict[KeyPath, tuple[int, int]] = {}

    def here(self) -> tuple[int, int]:
        return self.text.count("\n") + 1, len(self.text) - (self.text.rfind("\n") + 1) + 1

    def put(self, text: str) -> None:
        self.text += text

    def key(self, path: KeyPath, name: str) -> None:
        self.keys.setdefault(path, self.here())
        self.put(toml_key(name) if self.rng.random() < 0.8 else toml_string(name))

    def value(self, path: KeyPath, value: object) -> None:
        self.values[path] = self.here()
        if isinstance(value, dict):
            self.put("{ ")
            for n, (name, item) in enumerate(value.items()):
                self.put(", " if n else "")
                self.key((*path, name), name)
                self.put(" = ")
                self.value((*path, name), item)
            self.put(" }")
        elif isinstance(value, list):
            self.put("[")
            for n, item in enumerate(value):
                self.put(",\n  " if n and self.rng.random() < 0.3 else ", " if n else "")
                self.value((*path, n), item)
            self.put("]")
        elif isinstance(value, str):
            self.put(toml_string(value))
        else:
            self.put(str(value).lower() if isinstance(value, bool) else str(value))

    def table(self, path: KeyPath, names: tuple[str, ...], table: dict[str, object]) -> None:
        """The body of a table: plain and dotted keys first, then headers below it."""
        later = []
        for name, item in table.items():
            child = (*path, name)
            is_tables = isinstance(item, list) and item and all(isinstance(i, dict) for i in item)
            if (isinstance(item, dict) or is_tables) and self.rng.random() < 0.6:
                later.append((name, item))
            elif (isinstance(item, dict) and item and self.rng.random() < 0.5
                  and not any(isinstance(v, dict) for v in item.values())):
                for sub, value in item.items():  # dotted keys: name.sub = value
                    self.key(child, name)
                    self.put(" . " if self.rng.random() < 0.3 else ".")
                    self.key((*child, sub), sub)
                    self.put(" = ")
                    self.value((*child, sub), value)
                    self.put("  # note\n" if self.rng.random() < 0.2 else "\n")
            else:
                self.key(child, name)
                self.put(" = ")
                self.value(child, item)
                self.put("\n")
        for name, item in later:
            child = (*path, name)
            if isinstance(item, dict):
                self.header(child, (*names, name), item, "[", "]")
            else:
                assert isinstance(item, list)
                for index, element in enumerate(item):
                    self.header((*child, index), (*names, name), element, "[[", "]]")

    def header(self, path: KeyPath, names: tuple[str, ...], table: dict[str, object],
               open_: str, close: str) -> None:
        self.put("\n")
        self.values[path] = self.here()
        if open_ == "[[":
            self.keys.setdefault(path, self.here())
        self.put(open_)
        for n, name in enumerate(names):
            self.put("." if n else "")
            if n == len(names) - 1:
                key_path = path[:-1] if open_ == "[[" else path
                self.keys.setdefault(key_path, self.here())
                if open_ == "[":
                    self.keys.setdefault(path, self.here())
            self.put(toml_key(name))
        self.put(close + "\n")
        self.table(path, names, table)


_KEYS = st.one_of(st.from_regex(r"[A-Za-z0-9_-]{1,6}", fullmatch=True),
                  st.text(st.characters(exclude_categories=("Cs",)), min_size=0, max_size=6))
_SCALARS = st.one_of(st.integers(-10**6, 10**6), st.booleans(),
                     st.text(st.characters(exclude_categories=("Cs",)), max_size=8))


def _values(depth: int) -> st.SearchStrategy[object]:
    if depth == 0:
        return _SCALARS
    inner = _values(depth - 1)
    return st.one_of(_SCALARS, st.lists(inner, max_size=3),
                     st.dictionaries(_KEYS, inner, max_size=3),
                     st.lists(st.dictionaries(_KEYS, inner, max_size=3), min_size=1, max_size=2))


@settings(max_examples=150, deadline=None)
@given(st.dictionaries(_KEYS, _values(3), max_size=5), st.randoms(use_true_random=False))
def test_every_key_and_value_is_found_where_it_was_written(
    data: dict[str, object], rng: random.Random
) -> None:
    writer = _Writer(rng)
    writer.table((), (), data)
    document = read_toml("gen.toml", writer.text)
    assert document.data == tomllib.loads(writer.text) == data
    for path, place in writer.keys.items():
        assert document.keys[path][:2] == place, (path, writer.text)
    for path, place in writer.values.items():
        assert document.values[path][:2] == place, (path, writer.text)


def test_a_key_spans_its_text_as_written() -> None:
    document = read_toml("f.toml", '[masters."press 1"]\nretries = 3\na . "b" = 1\n')
    assert document.keys[("masters", "press 1")] == (1, 10, 9)
    assert document.keys[("masters", "press 1", "retries")] == (2, 1, 7)
    assert document.keys[("masters", "press 1", "a", "b")] == (3, 5, 3)
    assert str(document.value(("masters", "press 1"))) == "f.toml:1:1"


# --------------------------------------------------------------------- errors


def _error(text: str) -> str:
    with pytest.raises(DiagnosticError) as caught:
        read_toml("f.toml", text)
    (diagnostic,) = caught.value.diagnostics
    assert diagnostic.span is not None
    return f"{diagnostic.span}: {diagnostic.message} [{diagnostic.code}]"


def test_a_syntax_error_is_at_tomllib_position_without_its_position_text() -> None:
    assert _error("a = 1\nb = [1,\n  2 3]\n") == (
        "f.toml:3:5: not valid TOML: unclosed array [E400]")
    assert _error('a = "x\n') == "f.toml:1:7: not valid TOML: illegal character '\\n' [E400]"


def test_an_error_at_the_end_points_after_the_last_character() -> None:
    assert _error("a = [1,\n 2") == "f.toml:2:3: not valid TOML: unclosed array [E400]"


def test_nesting_too_deep_is_an_error_not_a_recursion_error() -> None:
    text = "a = " + "[" * 5000 + "]" * 5000
    assert _error(text) == (f"f.toml:1:{4 + MAX_NESTING + 1}: not valid TOML: arrays or "
                            f"tables nested more than {MAX_NESTING} deep [E400]")
    assert read_toml("ok.toml", "a = " + "[" * MAX_NESTING + "]" * MAX_NESTING).data


def test_brackets_in_strings_and_comments_do_not_count_as_nesting() -> None:
    text = f'a = "{"[" * 100}"  # {"{" * 100}\n'
    assert read_toml("f.toml", text).data == {"a": "[" * 100}


def test_unknown_keys_say_the_closest_known_one_at_the_key() -> None:
    document = read_toml("f.toml", "[master]\ncycle_m = 5\n")
    (found,) = document.unknown_keys(("master",), document.data["master"],  # type: ignore[arg-type]
                                     ("cycle_ms", "slaves"), "in [master]")
    assert f"{found.span}: {found.message} [{found.code}]" == (
        "f.toml:2:1: unknown key 'cycle_m' in [master]; did you mean 'cycle_ms'? "
        "(known: cycle_ms, slaves) [E407]")


def test_a_missing_place_falls_back_to_the_enclosing_one() -> None:
    document = read_toml("f.toml", "\n[t]\nx = 1\n")
    assert str(document.key(("t", "nothing", 3))) == "f.toml:2:2"
    assert str(document.key(("nowhere",))) == "f.toml:1:1"


@given(st.text(st.characters(exclude_categories=("Cs",)), max_size=30))
def test_toml_string_reads_back_as_the_same_text(text: str) -> None:
    assert tomllib.loads(f"k = {toml_string(text)}")["k"] == text
    assert tomllib.loads(f"{toml_key(text)} = 1") == {text: 1}


def test_inside_a_string_is_past_its_quotes() -> None:
    document = read_toml("f.toml", 'a = "xy"\nb = \'\'\'z\'\'\'\nc = [1, "q"]\n')
    assert str(document.inside(("a",))) == "f.toml:1:6"
    assert str(document.inside(("b",))) == "f.toml:2:8"
    assert str(document.inside(("c", 1))) == "f.toml:3:10"
