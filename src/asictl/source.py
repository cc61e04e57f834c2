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


def decode(raw: bytes) -> str:
    """Decode 8-bit source text, normalising line ends and dropping a DOS end-of-file mark.

    UTF-8 is tried first (modern editors). Otherwise the bytes are DOS or Windows text:
    bytes 80h..9Fh are control characters in Latin-1 but umlauts in CP850 (0x81 'ü',
    0x84 'ä', 0x94 'ö'), so their presence picks CP850.
    """
    end = raw.find(CTRL_Z)
    if end >= 0:
        raw = raw[:end]
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        codec = "cp850" if any(0x80 <= b <= 0x9F for b in raw) else "latin-1"
        text = raw.decode(codec)
    if text.startswith("\ufeff"):
        text = text[1:]
    return text.replace("\r\n", "\n").replace("\r", "\n")


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
