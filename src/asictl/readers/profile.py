"""A slave's profile as users write it, read one way wherever one is given (a scenario's
slaves, ``asictl testing``'s, plugging a slave into an emulated board): its I/O code,
letters such as ``iiio`` or a number 0..F, then its ID code (F when left out) and, where
a parameter is asked for, its power-up parameter; separated as a [SETUP] line separates
them (``16: iiio, 1, Eh``), by commas or blanks: ``iiio,1``, ``Bh,0,Eh``, ``7,F``.

A number is written as in IL, decimal or hex with an ``h`` (``11``, ``0Bh``), or as one
hex digit alone (``B``, ``F``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from asictl.platform.master import IO_CODES

_SEPARATOR = re.compile(r"\s*,\s*|\s+")
_NUMBER = re.compile(r"([0-9]+)d?|([0-9a-f]+)h|([0-9a-f])", re.IGNORECASE)


@dataclass(frozen=True)
class Profile:
    io_code: int
    id_code: int = 0xF
    #: the power-up parameter, where one was given
    parameter: int | None = None


def read_profile(text: str) -> Profile:
    """The profile ``text`` writes; ``ValueError`` says what is wrong."""
    fields = _SEPARATOR.split(text.strip())
    if not fields[0] or len(fields) > 3:
        raise ValueError(f"'{text}' is not 'I/O code[, ID[, parameter]]'")
    io_code = IO_CODES.get(fields[0].lower())
    if io_code is None:
        io_code = _digit(fields[0], text, "the I/O code is letters such as iiio or a number "
                                           "0..F such as Bh")
    given = [_digit(f, text, f"the {what} is a number 0..F such as 1 or Fh") if f else None
             for f, what in zip(fields[1:], ("ID code", "parameter"), strict=False)]
    id_code = given[0] if given and given[0] is not None else 0xF
    return Profile(io_code, id_code, given[1] if len(given) > 1 else None)


def _digit(field: str, text: str, expected: str) -> int:
    match = _NUMBER.fullmatch(field)
    value = None
    if match:
        decimal, hexadecimal, digit = match.groups()
        value = int(decimal) if decimal is not None else int(hexadecimal or digit, 16)
    if value is None or value > 0xF:
        raise ValueError(f"'{text}': {expected}")
    return value
