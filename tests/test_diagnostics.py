"""Rendering of diagnostics and reading of DOS-era source text."""

from __future__ import annotations

import json
import re

from asictl.diagnostics import (
    Diagnostic,
    Severity,
    Span,
    render_github,
    render_json,
    render_text,
)
from asictl.source import decode, from_bytes


def test_caret_under_the_column_with_length():
    d = Diagnostic(Severity.ERROR, "E201", "bad", Span("f.asi", 2, 7, 3))
    text = render_text([d], {"f.asi": "[PROGRAM]\n    A I 32.0\n"})
    assert text == "f.asi:2:7: error: bad [E201]\n      A I 32.0\n        ^~~\n"


def test_no_excerpt_for_unknown_file_or_line():
    d = Diagnostic(Severity.WARNING, "W1", "w", Span("g.asi", 9, 1))
    assert render_text([d], {"g.asi": "x\n"}) == "g.asi:9:1: warning: w [W1]\n"


def test_github_escapes_properties_and_message():
    d = Diagnostic(Severity.ERROR, "E1", "a%b\nc", Span("d:ir/f,1.asi", 1, 2))
    assert render_github([d]) == "::error file=d%3Air/f%2C1.asi,line=1,col=2,title=E1::a%25b%0Ac\n"


def test_decode_cp850_latin1_utf8_crlf_and_ctrl_z():
    assert decode(b"Z\x84hler\r\nx\x1agarbage") == "Zähler\nx"  # CP850 ä
    assert decode(b"Z\xe4hler\r\n") == "Zähler\n"  # Latin-1 ä
    assert decode("Zähler\r".encode()) == "Zähler\n"  # UTF-8, old Mac line end
    assert decode(b"\xef\xbb\xbfA") == "A"  # BOM


def test_source_keeps_raw_bytes():
    raw = b"[PROGRAM]\r\n\x1a"
    source = from_bytes("x.asi", raw)
    assert source.raw == raw and source.text == "[PROGRAM]\n"
    assert source.line(1) == "[PROGRAM]" and source.line(5) == ""


def test_notes_render_as_note_lines_with_their_source():
    d = Diagnostic(Severity.WARNING, "W701", "bad", Span("f.asi", 3, 9, 5),
                   notes=((Span("f.asi", 1, 1, 4), "set up here"),))
    text = render_text([d], {"f.asi": "1: iiii, 0\n[PROGRAM]\n    =   Q 1.0\n"})
    assert text == (
        "f.asi:3:9: warning: bad [W701]\n      =   Q 1.0\n          ^~~~~\n"
        "f.asi:1:1: note: set up here\n  1: iiii, 0\n  ^~~~\n"
    )


def test_json_has_notes_only_where_there_are_some():
    plain = Diagnostic(Severity.ERROR, "E201", "x", Span("f.asi", 2, 1))
    noted = Diagnostic(Severity.WARNING, "W711", "y", Span("f.asi", 5, 3),
                       notes=((Span("f.asi", 2, 3), "here too"),))
    items = json.loads(render_json([plain, noted]))
    assert "notes" not in items[0]
    assert items[1]["notes"] == [{"file": "f.asi", "line": 2, "column": 3, "message": "here too"}]


def test_github_annotations_carry_the_notes_in_the_message():
    d = Diagnostic(Severity.WARNING, "W711", "twice", Span("f.asi", 5, 3),
                   notes=((Span("f.asi", 2, 3), "here too"),))
    assert render_github([d]).endswith("::twice%0Af.asi:2:3: note: here too\n")


def test_colour_marks_location_severity_and_caret_and_nothing_else():
    d = Diagnostic(Severity.ERROR, "E201", "bad", Span("f.asi", 1, 3, 2),
                   notes=((Span("f.asi", 1, 1), "see"),))
    coloured = render_text([d], {"f.asi": "A I 32.0\n"}, colour=True)
    assert "\x1b[1;31merror:\x1b[0m" in coloured and "\x1b[1;36mnote:\x1b[0m" in coloured
    assert re.sub(r"\x1b\[[0-9;]*m", "", coloured) == render_text([d], {"f.asi": "A I 32.0\n"})
