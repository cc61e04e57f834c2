"""A slave's profile is read one way: the [SETUP] line's forms (the IL parser is the
oracle), and the short ones the command line takes (``7,F``, ``iiio`` with ID F)."""

from __future__ import annotations

import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from asictl.il import ast
from asictl.il.parser import parse_text
from asictl.platform.master import IO_CODE_BITS
from asictl.readers.profile import Profile, read_profile


def _setup(spec: str) -> tuple[int, int, int | None] | None:
    module, diagnostics = parse_text(f"[SETUP]\n5: {spec}\n", "<s>")
    sections = module.sections_of(ast.SetupSection)
    if diagnostics or not sections or not sections[0].slaves:
        return None
    slave = sections[0].slaves[0]
    return slave.io_code, slave.id_code, slave.parameter


def _number(value: int) -> st.SearchStrategy[str]:
    return st.sampled_from([str(value), f"{value:X}h", f"0{value:x}h", f"{value}d"])


codes = st.integers(0, 15)
io_codes = codes.flatmap(lambda c: st.one_of(
    _number(c), *([st.just(IO_CODE_BITS[c])] if c < 15 else [])))


@given(io_codes, codes.flatmap(_number), st.none() | codes.flatmap(_number),
       st.sampled_from([",", ", ", " ", " , "]))
def test_every_setup_line_form_reads_as_the_il_parser_reads_it(io, id_, parameter, sep):
    spec = sep.join([io, id_] + ([parameter] if parameter is not None else []))
    expected = _setup(spec)
    assert expected is not None, spec
    profile = read_profile(spec)
    assert (profile.io_code, profile.id_code, profile.parameter) == expected


@pytest.mark.parametrize(("text", "profile"), [
    ("iiio,1", Profile(1, 1)),
    ("Bh,0,Eh", Profile(11, 0, 14)),
    ("7,F", Profile(7, 15)),  # one hex digit alone
    ("B,0", Profile(11, 0)),
    ("iiio", Profile(1, 15)),  # the ID left out is F
    ("IIIO, 1", Profile(1, 1)),
])
def test_the_short_forms(text: str, profile: Profile):
    assert read_profile(text) == profile


@pytest.mark.parametrize(("text", "message"), [
    ("", "is not 'I/O code[, ID[, parameter]]'"),
    ("iiio,1,2,3", "is not 'I/O code[, ID[, parameter]]'"),
    ("zz,1", "the I/O code is letters such as iiio or a number 0..F"),
    ("16,1", "the I/O code is letters such as iiio or a number 0..F"),
    ("tttt,1", "the I/O code is letters such as iiio"),  # F has no letters
    ("iiio,10h", "the ID code is a number 0..F"),
    ("iiio,1,G", "the parameter is a number 0..F"),
])
def test_what_is_refused_says_why(text: str, message: str):
    with pytest.raises(ValueError, match=re.escape(message)):
        read_profile(text)
