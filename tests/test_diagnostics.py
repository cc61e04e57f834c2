"""Rendering of diagnostics and reading of DOS-era source text."""

from __future__ import annotations

import json
import re

from asictl.diagnostics import (
    Diagnostic,
    Severity,
    Span,
    printable,
    render_github,
    render_json,
    render_text,
)
from asictl.source import decode, from_bytes


def test_caret_under_the_column_with_length():
    d = Diagnostic(Severity.ERROR, "E201", "bad", Span("f.asi", 2, 7, 3))
    text = render_text([d], {"f.asi": "[PROGRAM]\n    A I 32.0\n"})
    assert text == "f.asi:2:7: error: bad [E201]\n      A I 32.0\n        ^~~\n"


def test_control_characters_from_a_file_reach_no_terminal_and_the_caret_stays_put():
    """A comment, a file name or a message with ESC, BEL, CR or a C1 code is shown escaped
    (as HTML escapes it), and the caret still points at the column."""
    line = "  ; \x1b]0;owned\x07 \r\x9b A I 32.0"
    d = Diagnostic(Severity.ERROR, "E201", "bad \x1b[2J", Span("f\x1b.asi", 1, 20, 1))
    text = render_text([d], {"f\x1b.asi": line + "\n"})
    assert text.splitlines() == [
        "f\\x1b.asi:1:20: error: bad \\x1b[2J [E201]",
        "    ; \\x1b]0;owned\\x07 \\r\\x9b A I 32.0",
        "                               ^",
    ]
    assert text.splitlines()[1][text.splitlines()[2].index("^")] == line[19]


def test_printable_keeps_lines_and_tabs_of_a_message_only():
    assert printable("a\tb\nc") == "a\tb\nc"
    assert printable("a\tb\nc", lines=False) == "a\\tb\\nc"
    assert printable("Füße 16ms") == "Füße 16ms"
    assert printable("\u202eevil") == "\\u202eevil"


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


def test_related_locations_are_note_lines_with_their_excerpt():
    first = Span("f.asi", 2, 1, 2)
    d = Diagnostic(Severity.ERROR, "E210", "twice", Span("f.asi", 3, 1, 2),
                   ((first, "first set up here"),))
    text = render_text([d], {"f.asi": "[SETUP]\n16: 8h, 0\n16: 0h, 0\n"})
    assert text.splitlines() == [
        "f.asi:3:1: error: twice [E210]", "  16: 0h, 0", "  ^~",
        "f.asi:2:1: note: first set up here", "  16: 8h, 0", "  ^~",
    ]


def test_related_locations_in_json_and_github():


    d = Diagnostic(Severity.WARNING, "W203", "again", Span("f.asi", 3, 1),
                   ((Span("f.asi", 2, 1), "first given here"),))
    item = json.loads(render_json([d]))[0]
    assert item["related"] == [{"file": "f.asi", "line": 2, "column": 1,
                                "message": "first given here"}]
    plain = Diagnostic(Severity.WARNING, "W1", "w", Span("f.asi", 1, 1))
    assert "related" not in json.loads(render_json([plain]))[0]
    assert render_github([d]).endswith("::again%0Anote: f.asi:2:1: first given here\n")


def test_checks_attach_the_first_definition_as_related():
    from asictl.il.checks import check_source
    from asictl.source import from_string

    text = "[SETUP]\n16: 8h, 0\n16: 0h, 0\n[PROGRAM]\nx: A I 1.0\nX: = Q 16.0\n"
    result = check_source(from_string("d.asi", text))
    related = {d.code: d.related for d in result.diagnostics}
    assert related["E210"] == ((Span("d.asi", 2, 1, 9), "first set up here"),)
    assert related["E205"] == ((Span("d.asi", 5, 1, 1), "first defined here"),)


def test_colour_marks_location_severity_and_caret_and_nothing_else():
    d = Diagnostic(Severity.ERROR, "E201", "bad", Span("f.asi", 1, 3, 2),
                   related=((Span("f.asi", 1, 1), "see"),))
    coloured = render_text([d], {"f.asi": "A I 32.0\n"}, colour=True)
    assert "\x1b[1;31merror:\x1b[0m" in coloured and "\x1b[1;36mnote:\x1b[0m" in coloured
    assert re.sub(r"\x1b\[[0-9;]*m", "", coloured) == render_text([d], {"f.asi": "A I 32.0\n"})
