"""The line map: which IL source line each byte of a program's code implements.

The compiler knows it (every generated assembly line remembers its IL statement); the
image carries it (docs/image-format.md), so that a master running an uploaded image, the
simulator and the debugger can name the IL line of an address: where a cycle time-out
cut a program off, where a breakpoint is, which line a trace row belongs to.

The map is a list of address ranges, each running up to the next one's start. A range
either belongs to one line of one file or to no IL line at all (the cycle entry, the
runtime's helper subroutines, a block's final return).
"""

from __future__ import annotations

import bisect
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import PurePath

from asictl.diagnostics import Span

#: The file index a range without an IL line has in the encoded map.
_NO_FILE = 0xFF


class LineMapError(ValueError):
    """An encoded line map that does not decode (cut short, indices out of range)."""


@dataclass(frozen=True, slots=True, order=True)
class SourceLine:
    """One line of one source file (stored by base name, as the image stores sources)."""

    file: str
    line: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}"


@dataclass(frozen=True)
class LineMap:
    """Code address ranges -> IL lines; see the module docstring."""

    files: tuple[str, ...] = ()
    #: (start address, file index or None, line), by address; each range ends where the
    #: next begins, the last one at ``end``
    ranges: tuple[tuple[int, int | None, int], ...] = ()
    end: int = 0
    _starts: tuple[int, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_starts", tuple(start for start, _, _ in self.ranges))

    def __bool__(self) -> bool:
        return bool(self.ranges)

    @classmethod
    def build(cls, spans: Iterable[tuple[int, int, Span | None]]) -> LineMap:
        """The map of code pieces: (address, length, IL span or None), in any order.

        Adjacent pieces of one line merge into one range; files are stored by base name
        in the order they first appear.
        """
        files: list[str] = []
        ranges: list[tuple[int, int | None, int]] = []
        end = 0
        for address, length, span in sorted(spans, key=lambda piece: piece[0]):
            if length <= 0:
                continue
            if span is None:
                index, line = None, 0
            else:
                name = PurePath(span.file).name or span.file
                if name not in files:
                    files.append(name)
                index, line = files.index(name), span.line
            if ranges and end == address and ranges[-1][1:] == (index, line):
                end = address + length
                continue
            if ranges and end != address:  # a gap (ORG in [ASSEMBLY] code): no line there
                ranges.append((end, None, 0))
            ranges.append((address, index, line))
            end = address + length
        return cls(tuple(files), tuple(ranges), end)

    def line_at(self, address: int) -> SourceLine | None:
        """The IL line whose code holds ``address``, if any."""
        i = bisect.bisect_right(self._starts, address) - 1
        if i < 0 or address >= self.end:
            return None
        _, index, line = self.ranges[i]
        return None if index is None else SourceLine(self.files[index], line)

    def line_starts(self) -> dict[int, SourceLine]:
        """Start address -> line, for every range that belongs to a line."""
        return {
            start: SourceLine(self.files[index], line)
            for start, index, line in self.ranges
            if index is not None
        }

    def lines(self) -> list[SourceLine]:
        """Every line that has code, in file and line order."""
        return sorted(set(self.line_starts().values()))

    # ------------------------------------------------------------------ encoding

    def to_bytes(self, code_base: int) -> bytes:
        """The compact form the image stores (docs/image-format.md, "Line map")."""
        out = bytearray([len(self.files)])
        for name in self.files:
            encoded = name.encode("utf-8")
            out += bytes([len(encoded)]) + encoded
        out += _uleb(len(self.ranges))
        previous_start, previous_line, previous_file = code_base, 0, _NO_FILE
        for start, index, line in self.ranges:
            file_code = _NO_FILE if index is None else index
            out += _uleb(start - previous_start)
            changed = file_code != previous_file
            out += _uleb(_zigzag(line - previous_line) << 1 | changed)
            if changed:
                out.append(file_code)
            previous_start, previous_line, previous_file = start, line, file_code
        out += _uleb(self.end - previous_start if self.ranges else 0)
        return bytes(out)

    @classmethod
    def from_bytes(cls, data: bytes, code_base: int) -> LineMap:
        reader = _Reader(data)
        files = []
        for _ in range(reader.byte()):
            raw = reader.take(reader.byte())
            try:
                name = raw.decode("utf-8")
            except UnicodeDecodeError:
                raise LineMapError("a file name is not UTF-8 text") from None
            if not name.isprintable() or "/" in name or "\\" in name:
                # it is printed in stop messages: no control sequences, no paths
                raise LineMapError(f"the file name {name!r} is not a plain printable name")
            files.append(name)
        ranges: list[tuple[int, int | None, int]] = []
        start, line, file_code = code_base, 0, _NO_FILE
        for _ in range(reader.uleb()):
            start += reader.uleb()
            packed = reader.uleb()
            line += _unzigzag(packed >> 1)
            if packed & 1:
                file_code = reader.byte()
            if file_code != _NO_FILE and file_code >= len(files):
                raise LineMapError(f"file index {file_code}, but {len(files)} files")
            if line < 0:
                raise LineMapError("a negative line number")
            ranges.append((start, None if file_code == _NO_FILE else file_code, line))
        end = start + reader.uleb()
        if not reader.at_end():
            raise LineMapError(f"{len(data) - reader.offset} unexpected bytes at the end")
        return cls(tuple(files), tuple(ranges), end if ranges else 0)


def _uleb(value: int) -> bytes:
    if value < 0:
        raise ValueError(f"a line map number is never negative: {value}")
    out = bytearray()
    while True:
        byte, value = value & 0x7F, value >> 7
        if value:
            out.append(byte | 0x80)
        else:
            out.append(byte)
            return bytes(out)


def _zigzag(value: int) -> int:
    return value << 1 if value >= 0 else (-value << 1) - 1


def _unzigzag(value: int) -> int:
    return value >> 1 if not value & 1 else -((value + 1) >> 1)


class _Reader:
    def __init__(self, data: Sequence[int]) -> None:
        self.data, self.offset = bytes(data), 0

    def byte(self) -> int:
        return self.take(1)[0]

    def take(self, n: int) -> bytes:
        if self.offset + n > len(self.data):
            raise LineMapError(f"cut short: needs {self.offset + n} bytes, has {len(self.data)}")
        chunk = self.data[self.offset : self.offset + n]
        self.offset += n
        return chunk

    def uleb(self) -> int:
        value = shift = 0
        while True:
            byte = self.byte()
            value |= (byte & 0x7F) << shift
            shift += 7
            if not byte & 0x80:
                return value
            if shift > 28:
                raise LineMapError("a number is implausibly long")

    def at_end(self) -> bool:
        return self.offset == len(self.data)
