"""Rendering of diagnostics and reading of DOS-era source text."""

from __future__ import annotations

from asictl.diagnostics import Diagnostic, Severity, Span, render_github, render_text
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
