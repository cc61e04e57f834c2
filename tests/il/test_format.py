"""The formatter: a canonical layout that never changes a program, its comments, its
blank lines, its encoding or its line ends, and that formatting again leaves alone."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from il_strategies import modules

from asictl.diagnostics import DiagnosticError
from asictl.il import ast
from asictl.il.format import format_source, format_text
from asictl.il.parser import parse_text
from asictl.source import from_bytes

DEMOS = Path(__file__).resolve().parents[2] / "demos"

MESSY = """\
; header comment
[options]
auto_start yes
  ignore_config_errors :  no   ; a comment

[SETUP]
16 iiio 1 Eh ; sixteen
 3:Bh,0
[DECL]
Reading BYTE 5 T134 TIMER
MeanValue    FB   mean.fb
C 27 COUNTER
[PROGRAM]
start: a i 16.0 ; lower case stays
   AN "I 16.1"
 = Q 3.0
***
    L KB 0Ah
 T   FY 3
averyverylonglabel: JC=start
goesoff: L KT 700
 ASM mov a,  #12h
end:
    BE
[GATING]
Q 3.1=I 16.0   or not  F 1.0
[ASSEMBLY]
   nop   ;  kept as written
[END] anything  goes   here
"""

EXPECTED = """\
; header comment
[options]
auto_start:           yes
ignore_config_errors: no    ; a comment

[SETUP]
16: iiio, 1, Eh             ; sixteen
3:  Bh, 0
[DECL]
Reading BYTE 5  T134 TIMER
MeanValue  FB mean.fb
C 27       COUNTER
[PROGRAM]
start:  a   i 16.0          ; lower case stays
        AN  I 16.1
        =   Q 3.0
***
        L   KB 0Ah
        T   FY 3
averyverylonglabel: JC = start
goesoff: L  KT 700
        ASM mov a,  #12h
end:
        BE
[GATING]
Q 3.1 = I 16.0 or not F 1.0
[ASSEMBLY]
   nop   ;  kept as written
[END] anything  goes   here
"""


def test_the_canonical_layout():
    assert format_text(MESSY, "m.asi") == EXPECTED
    assert format_text(EXPECTED, "m.asi") == EXPECTED


def test_syntax_errors_are_refused_with_their_diagnostics():
    with pytest.raises(DiagnosticError) as caught:
        format_text("[PROGRAM]\n    A\n", "bad.asi")
    assert [d.code for d in caught.value.diagnostics] == ["E102"]


def test_encoding_line_ends_bom_and_ctrl_z_are_kept():
    raw = "[PROGRAM]\r\n A I 1.0 ; Zähler\r\n = Q 2.0\r\n".encode("cp850") + b"\x1aJUNK"
    out = format_source(from_bytes("d.asi", raw))
    expected = "[PROGRAM]\r\n        A   I 1.0           ; Zähler\r\n        =   Q 2.0\r\n"
    assert out == expected.encode("cp850") + b"\x1aJUNK"
    latin = "[PROGRAM]\n A I 1.0 ; Zähler\n".encode("latin-1")
    assert format_source(from_bytes("l.asi", latin)).decode("latin-1").endswith("; Zähler\n")
    bom = b"\xef\xbb\xbf[PROGRAM]\n A I 1.0"  # no final line end either
    assert format_source(from_bytes("b.asi", bom)) == b"\xef\xbb\xbf[PROGRAM]\n        A   I 1.0"


def test_the_demos_are_in_canonical_layout():
    for path in sorted(DEMOS.glob("*.asi")) + sorted(DEMOS.glob("*.fb")):
        raw = path.read_bytes()
        assert format_source(from_bytes(str(path), raw)) == raw, path.name


# ------------------------------------------------------------- generated programs


def _comments(text: str) -> list[str]:
    return [line[line.index(";"):].rstrip() for line in text.split("\n") if ";" in line]


_WHITE_RUNS = st.sampled_from([" ", "  ", "\t", " \t "])
_BLANK_RUNS = _WHITE_RUNS | st.sampled_from([", ", " ' "])


@st.composite
def scrambled(draw: st.DrawFn, text: str) -> str:
    """``text`` with the layout an engineer might have typed: other blanks and indents,
    blank-like punctuation, labels on their instruction's line, several declarations on
    a line, comments and blank lines. None of it changes the program."""
    out: list[str] = []
    section = ""
    lines = text.split("\n")
    i = 0
    while i < len(lines):
        line = lines[i]
        i += 1
        if line.startswith("["):
            section = line
            out.append(draw(st.sampled_from(["", " ", "\t"])) + line)
            continue
        if not line.strip() or section in ("[ASSEMBLY]", "[RAW]"):
            out.append(line)
            continue
        if section == "[PROGRAM]" and line.endswith(":") and i < len(lines) and \
                lines[i].startswith("    ") and draw(st.booleans()):
            line = line + draw(_BLANK_RUNS) + lines[i].strip()
            i += 1
        if section == "[DECL]" and i < len(lines) and lines[i] and not lines[i].startswith("[") \
                and draw(st.booleans()):
            line = line + " " + lines[i]
            i += 1
        if " ASM " in f" {line.strip()} ":
            head, _, asm_text = line.partition("ASM ")
            line = head + "ASM" + draw(st.sampled_from([" ", "\t", "   "])) + asm_text
        else:
            blanks = _WHITE_RUNS if section == "[DECL]" else _BLANK_RUNS  # not in file names
            line = re.sub(" ", lambda _, runs=blanks: draw(runs), line.strip())
            line = draw(st.sampled_from(["", " ", "\t", "        "])) + line
        if draw(st.booleans()):
            line += draw(st.sampled_from([" ", "\t", ""])) + "; " + draw(
                st.text(st.characters(codec="latin-1", exclude_characters="\n\r\x1a"), max_size=8))
        out.append(line)
        if draw(st.integers(0, 5)) == 0:
            out.append(draw(st.sampled_from(["", "; a comment line", "   ;indented"])))
    return "\n".join(out)


@settings(max_examples=50, deadline=None)
@given(st.data(), modules(file="gen.asi"))
def test_format_keeps_the_program_and_is_idempotent(data: st.DataObject, module: ast.Module):
    format_keeps_the_program_and_is_idempotent(data, module)


@pytest.mark.slow
@settings(max_examples=400, deadline=None)
@given(st.data(), modules(file="gen.asi"))
def test_format_keeps_the_program_and_is_idempotent_long(
    data: st.DataObject, module: ast.Module
) -> None:
    format_keeps_the_program_and_is_idempotent(data, module)


def format_keeps_the_program_and_is_idempotent(data: st.DataObject, module: ast.Module) -> None:
    text = data.draw(scrambled(module.to_source()))
    original, diagnostics = parse_text(text, "gen.asi")
    assert diagnostics == [], text
    assert original == module
    formatted = format_text(text, "gen.asi")
    again, diagnostics = parse_text(formatted, "gen.asi")
    assert diagnostics == [] and again == module
    assert format_text(formatted, "gen.asi") == formatted
    assert formatted.count("\n") == text.count("\n")
    assert _comments(formatted) == [c.rstrip() for c in _comments(text)]
    assert [bool(line.strip()) for line in formatted.split("\n")] == [
        bool(line.strip()) for line in text.split("\n")]


def test_control1_titles_raw_records_and_end_without_brackets():
    text = "SETUP\n 5 oooo 0\nPROGRAM ; old style\nA I 5.0\n= Q 5.1\nEND\n  garbage ; x  \n"
    assert format_text(text, "c1.asi") == (
        "SETUP\n5: oooo, 0\nPROGRAM                     ; old style\n        A   I 5.0\n"
        "        =   Q 5.1\nEND\n  garbage ; x  \n")
    raw = "[RAW]\n  :00000001FF   ; end record\n[END]\n"
    assert format_text(raw, "r.asi") == "[RAW]\n:00000001FF                 ; end record\n[END]\n"
