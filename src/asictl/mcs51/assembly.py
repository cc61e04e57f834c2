"""The result of assembling: code bytes, symbols, listing, and where each byte came from.

The IL compiler maps machine addresses back to its own source through ``origin``, and
the CLI writes the Intel HEX, listing and symbol files from here, so all three formats
are produced in one place.
"""

from __future__ import annotations

import bisect
import io
from collections.abc import Mapping
from dataclasses import dataclass, field

from intelhex import IntelHex

from asictl.diagnostics import Diagnostic, Span


@dataclass(frozen=True, slots=True)
class Symbol:
    name: str  # as spelled where it was defined
    value: int
    #: label, EQU, SET, BIT, DATA, IDATA, XDATA, CODE, or predefined (by the caller)
    kind: str
    span: Span | None = None


@dataclass(frozen=True, slots=True)
class ListingEntry:
    """One source line: where it was assembled and what it produced (often nothing)."""

    #: The location counter at the line; None for lines that are not about code
    #: (comments, symbol definitions).
    address: int | None
    data: bytes
    #: Machine cycles of an instruction; None for directives, labels and comments.
    cycles: int | None
    #: File and line of the source; column 1, spanning the whole line.
    span: Span
    text: str


#: Bytes shown on one listing row; longer DB/DW data continues on further rows.
_LISTING_BYTES_PER_ROW = 4


@dataclass(frozen=True)
class Assembly:
    """An assembled program. ``segments`` are contiguous runs of code, sorted by address."""

    segments: tuple[tuple[int, bytes], ...]
    symbols: Mapping[str, Symbol]
    listing: tuple[ListingEntry, ...]
    #: Warnings; an assembly with errors raises ``DiagnosticError`` instead.
    diagnostics: tuple[Diagnostic, ...] = ()
    _origins: tuple[tuple[int, ListingEntry], ...] = field(init=False, repr=False)
    _origin_starts: tuple[int, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        origins = sorted(
            ((e.address, e) for e in self.listing if e.data and e.address is not None),
            key=lambda pair: pair[0],
        )
        object.__setattr__(self, "_origins", tuple(origins))
        object.__setattr__(self, "_origin_starts", tuple(start for start, _ in origins))

    @property
    def size(self) -> int:
        """Number of code bytes."""
        return sum(len(data) for _, data in self.segments)

    def byte_map(self) -> dict[int, int]:
        """Address -> byte for every assembled byte."""
        return {start + i: b for start, data in self.segments for i, b in enumerate(data)}

    def origin(self, address: int) -> ListingEntry | None:
        """The source line that produced the byte at ``address``, if any did."""
        i = bisect.bisect_right(self._origin_starts, address) - 1
        if i >= 0:
            start, entry = self._origins[i]
            if address < start + len(entry.data):
                return entry
        return None

    def to_intelhex(self) -> IntelHex:
        image = IntelHex()
        for start, data in self.segments:
            image.frombytes(data, offset=start)
        return image

    def to_hex(self) -> str:
        """Intel HEX text, 16 data bytes per record, ending in an EOF record."""
        out = io.StringIO()
        self.to_intelhex().write_hex_file(out, byte_count=16)
        return out.getvalue()

    def listing_text(self) -> str:
        """A listing: address, code bytes, cycles, line number and source of every line.

        A file header line separates the sources of a multi-file assembly.
        """
        rows = ["ADDR  CODE         CYC   LINE  SOURCE"]
        current_file = None
        for entry in self.listing:
            if entry.span.file != current_file:
                current_file = entry.span.file
                rows.append(f"; {current_file}")
            start, step = entry.address, _LISTING_BYTES_PER_ROW
            address = "    " if start is None else f"{start:04X}"
            cycles = "" if entry.cycles is None else str(entry.cycles)
            rows.append(
                f"{address}  {entry.data[:step].hex(' ').upper():<12} {cycles:>3} "
                f"{entry.span.line:>6}  {entry.text}".rstrip()
            )
            if start is not None:  # always so for a line with data
                for offset in range(step, len(entry.data), step):
                    chunk = entry.data[offset : offset + step].hex(" ").upper()
                    rows.append(f"{start + offset:04X}  {chunk}")
        return "\n".join(rows) + "\n"

    def symbol_table_text(self) -> str:
        """The program's own symbols (not the predefined SFR names), sorted by name."""
        width = max((len(s.name) for s in self.symbols.values()), default=4)
        rows = [f"{'NAME':<{width}}  VALUE  KIND"]
        for symbol in sorted(self.symbols.values(), key=lambda s: s.name.upper()):
            value = f"{symbol.value:04X}" if symbol.value >= 0 else str(symbol.value)
            rows.append(f"{symbol.name:<{width}}  {value:>5}  {symbol.kind}")
        return "\n".join(rows) + "\n"
