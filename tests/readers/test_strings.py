"""Columns inside TOML strings, against tomllib itself: the raw text up to the column
found for character i of a string decodes to exactly its first i characters."""

from __future__ import annotations

import json
import tomllib

from hypothesis import given
from hypothesis import strategies as st

from asictl.readers.strings import string_column, value_column


@given(st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x7f"),
               max_size=30), st.booleans())
def test_a_column_in_a_basic_string_is_where_its_character_starts(text: str, escape: bool):
    if escape and any(ord(c) > 0xFFFF for c in text):
        text = "".join(c for c in text if ord(c) <= 0xFFFF)  # JSON would pair surrogates
    line = f"when = {json.dumps(text, ensure_ascii=escape)}  # note"
    quote = line.index('"')
    for offset in range(len(text) + 1):
        column = string_column(line, quote, offset)
        prefix = line[quote:column - 1] + '"'
        assert tomllib.loads(f"k = {prefix}")["k"] == text[:offset]


def test_literal_strings_have_no_escapes_and_the_key_finds_its_value():
    line = r"never = 'Q 2.0 \and'"
    assert value_column(line, 1, 7) == line.index("\\and") + 2  # the a after one backslash
    assert value_column('a = "x\\ty"', 1, 2) == 9  # after the two characters of \t
    assert value_column('a = "\\U0001F600x"', 1, 1) == 16  # after \U and eight digits
    assert value_column("a = 3", 1, 0) is None
