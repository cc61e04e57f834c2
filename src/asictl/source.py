"""Reading source files the way the DOS-era tools wrote them.

Programs written on the original tools are 8-bit text: German comments in CP850 or
Latin-1, CR LF line ends, and often a trailing Ctrl-Z (the DOS end-of-file mark). They
are read without complaint; the raw bytes are kept so that an image can carry the exact
source back to the engineer on upload.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from asictl.errors import UserError

CTRL_Z = b"\x1a"


@dataclass(frozen=True)
class SourceText:
    """One source file: its display name, its decoded text and the bytes it came from."""

    name: str
    text: str
    raw: bytes

    def line(self, number: int) -> str:
        """The text of 1-based line ``number``, or '' past the end."""
        lines = self.text.split("\n")
        return lines[number - 1] if 0 < number <= len(lines) else ""


UTF8_BOM = "\ufeff"


def decode(raw: bytes) -> str:
    """Decode 8-bit source text, normalising line ends and dropping a DOS end-of-file mark.

    UTF-8 is tried first (modern editors). Otherwise the bytes are DOS or Windows text:
    bytes 80h..9Fh are control characters in Latin-1 but umlauts in CP850 (0x81 'ü',
    0x84 'ä', 0x94 'ö'), so their presence picks CP850.
    """
    body = _body(raw)
    text = body.decode(_codec(body))
    if text.startswith(UTF8_BOM):
        text = text[1:]
    return text.replace("\r\n", "\n").replace("\r", "\n")


def _body(raw: bytes) -> bytes:
    """The bytes before the DOS end-of-file mark."""
    end = raw.find(CTRL_Z)
    return raw if end < 0 else raw[:end]


def _codec(body: bytes) -> str:
    try:
        body.decode("utf-8")
    except UnicodeDecodeError:
        return "cp850" if any(0x80 <= b <= 0x9F for b in body) else "latin-1"
    return "utf-8"


@dataclass(frozen=True)
class TextForm:
    """How a file's bytes carry its text, so that a tool that rewrites the text (a
    formatter) writes it back the way the engineer's tools wrote it."""

    codec: str
    bom: bool
    #: the file's line end: the most frequent of CR LF, LF and a lone CR
    newline: str
    #: a DOS end-of-file mark and whatever follows it, kept byte for byte
    tail: bytes

    def encode(self, text: str) -> bytes:
        """``text`` (with LF line ends, as ``decode`` gives it) in this form."""
        body = (UTF8_BOM if self.bom else "") + text.replace("\n", self.newline)
        return body.encode(self.codec) + self.tail


def text_form(raw: bytes) -> TextForm:
    body = _body(raw)
    codec = _codec(body)
    crlf = body.count(b"\r\n")
    counts = {"\r\n": crlf, "\n": body.count(b"\n") - crlf, "\r": body.count(b"\r") - crlf}
    newline = max(counts, key=lambda end: (counts[end], end == "\n"))
    return TextForm(codec, codec == "utf-8" and body.startswith(UTF8_BOM.encode()), newline,
                    raw[len(body):])


def from_bytes(name: str, raw: bytes) -> SourceText:
    return SourceText(name=name, text=decode(raw), raw=raw)


def from_string(name: str, text: str) -> SourceText:
    return SourceText(name=name, text=decode(text.encode("utf-8")), raw=text.encode("utf-8"))


def read_source(path: str | Path) -> SourceText:
    """Read a source file ('-' is standard input); unreadable files are a ``UserError``."""
    name = str(path)
    try:
        raw = sys.stdin.buffer.read() if name == "-" else Path(path).read_bytes()
    except OSError as exc:
        raise UserError(f"{name}: cannot read: {exc.strerror or exc}") from None
    return from_bytes("<stdin>" if name == "-" else name, raw)
