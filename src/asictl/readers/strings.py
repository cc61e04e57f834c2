"""Where a character of a TOML string value stands on its line.

A mistake inside a string (a condition's offending token, say) is reported at the
file's line and column of that character, not at the key. TOML decodes the string
first, so an offset in the decoded text is mapped back through the quotes and the
escapes of a basic string (``"a\\"b"``, ``"\\u00e9"``); a literal string (``'...'``)
has none. Multi-line strings are not followed past their first line.
"""

from __future__ import annotations

#: Escapes of a basic string and how many characters follow the backslash.
_ESCAPE_LENGTH = {"u": 5, "U": 9}


def value_column(line: str, key_column: int, offset: int) -> int | None:
    """The 1-based column of character ``offset`` of the string value of the key that
    starts at ``key_column`` (1-based) on ``line``; None if no string follows the key."""
    equals = line.find("=", key_column - 1)
    if equals < 0:
        return None
    quotes = [i for i in (line.find('"', equals), line.find("'", equals)) if i >= 0]
    if not quotes:
        return None
    return string_column(line, min(quotes), offset)


def string_column(line: str, quote: int, offset: int) -> int:
    """The 1-based column of decoded character ``offset`` of the string whose opening
    quote is at index ``quote`` of ``line``."""
    literal = line[quote] == "'"
    at = quote + (3 if line.startswith(line[quote] * 3, quote) else 1)
    for _ in range(offset):
        if at >= len(line):
            break
        if not literal and line[at] == "\\" and at + 1 < len(line):
            at += _ESCAPE_LENGTH.get(line[at + 1], 1) + 1
        else:
            at += 1
    return at + 1
