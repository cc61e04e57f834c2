"""Reading source files the way the DOS-era tools wrote them.

Programs written on the original tools are 8-bit text: German comments in CP850 or
Latin-1, CR LF line ends, and often a trailing Ctrl-Z (the DOS end-of-file mark). They
are read without complaint; the raw bytes are kept so that an image can carry the exact
source back to the engineer on upload.
"""

from __future__ import annotations

import os
import re
import stat
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from asictl.errors import UserError

CTRL_Z = b"\x1a"
#: The largest source file read. Programs are a few hundred KB at most (the EEPROM the
#: program lands in holds 16 KB); more is a wrong file, or a device such as /dev/zero.
MAX_SOURCE_BYTES = 8 * 1024 * 1024
#: A program's symbol table lives beside it: ``conveyor.asi`` -> ``conveyor.symbols.toml``
#: (read by ``observe.symbols``; an image carries it with the source).
SYMBOLS_SUFFIX = ".symbols.toml"


def symbols_path(program: str | Path) -> Path:
    """Where a program's symbol table is: ``conveyor.asi`` -> ``conveyor.symbols.toml``."""
    path = Path(program)
    return path.with_name(path.stem + SYMBOLS_SUFFIX)


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
    #: each line's own end, in order: a file with mixed line ends keeps them line by line
    ends: tuple[str, ...] = ()

    def encode(self, text: str) -> bytes:
        """``text`` (with LF line ends, as ``decode`` gives it) in this form: line n ends
        as line n of the file did (lines beyond those the file had end with ``newline``)."""
        lines = text.split("\n")
        ends = list(self.ends[: len(lines) - 1])
        ends += [self.newline] * (len(lines) - 1 - len(ends))
        body = "".join(line + end for line, end in zip(lines, [*ends, ""], strict=True))
        return ((UTF8_BOM if self.bom else "") + body).encode(self.codec) + self.tail


def text_form(raw: bytes) -> TextForm:
    body = _body(raw)
    codec = _codec(body)
    ends = tuple(end.decode("ascii") for end in re.findall(rb"\r\n|\r|\n", body))
    counts = Counter(ends)
    newline = max(("\r\n", "\n", "\r"), key=lambda end: (counts[end], end == "\n"))
    return TextForm(codec, codec == "utf-8" and body.startswith(UTF8_BOM.encode()), newline,
                    raw[len(body):], ends)


def from_bytes(name: str, raw: bytes) -> SourceText:
    return SourceText(name=name, text=decode(raw), raw=raw)


def from_string(name: str, text: str) -> SourceText:
    return SourceText(name=name, text=decode(text.encode("utf-8")), raw=text.encode("utf-8"))


def read_source(path: str | Path) -> SourceText:
    """Read a source file ('-' is standard input); unreadable files are a ``UserError``."""
    name = str(path)
    raw = read_bounded(path, MAX_SOURCE_BYTES, "a source file")
    return from_bytes("<stdin>" if name == "-" else name, raw)


def read_bounded(path: str | Path, limit: int, what: str) -> bytes:
    """The bytes of ``path`` ('-' is standard input), refused if there are more than
    ``limit``: ``what`` names the kind of file for the message.

    At most ``limit`` + 1 bytes are read, so /dev/zero or a huge file given by mistake is
    refused without filling the memory. A FIFO is opened without waiting for a writer
    (a plain open would block forever when there is none) and then read to its end, so
    ``<(command)`` works and a FIFO nobody writes to reads as empty.
    """
    name = str(path)
    data = sys.stdin.buffer.read(limit + 1) if name == "-" else _read_file(name, limit + 1)
    if len(data) > limit:
        raise UserError(
            f"{'<stdin>' if name == '-' else name}: more than {_size(limit)}, too large for "
            f"{what}; not read"
        )
    return data


def check_readable(path: str | Path) -> None:
    """A ``UserError`` now, as reading would raise it later, for a file that cannot be
    read ('-' always can): a command checks before it opens a board, since opening an
    emulated board that is not there creates one. Nothing is read (a FIFO keeps its data)."""
    if str(path) != "-":
        os.close(_open(str(path)))


def _open(name: str) -> int:
    """A descriptor for reading ``name``, refused for a directory or a missing file."""
    try:
        fd = os.open(name, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as exc:
        raise UserError(f"{name}: cannot read: {exc.strerror or exc}") from None
    if stat.S_ISDIR(os.fstat(fd).st_mode):
        os.close(fd)
        raise UserError(f"{name}: cannot read: it is a directory")
    return fd


def _read_file(name: str, size: int) -> bytes:
    fd = _open(name)
    try:
        os.set_blocking(fd, True)
        chunks: list[bytes] = []
        left = size
        while left > 0:
            chunk = os.read(fd, min(left, 1 << 20))
            if not chunk:
                break
            chunks.append(chunk)
            left -= len(chunk)
        return b"".join(chunks)
    except OSError as exc:
        raise UserError(f"{name}: cannot read: {exc.strerror or exc}") from None
    finally:
        os.close(fd)


def _size(limit: int) -> str:
    return f"{limit // (1024 * 1024)} MB" if limit >= 1024 * 1024 else f"{limit // 1024} KB"
