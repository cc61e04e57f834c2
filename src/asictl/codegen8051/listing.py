"""The compile listing (the manual's CTRL.{a}) and the summaries the verbose log shares.

The listing answers "what did this IL line become, and what does it cost": every source
line in order, each followed by the assembly generated for it with address, bytes and
machine cycles, then where the program's data went, then the cross-reference (which
lines read and write each operand). It is built from the generated
assembly's IL spans and the assembler's per-line listing, so it shows exactly the code
in the image.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

from asictl import __version__
from asictl.codegen8051.compiler import GENERATED, Compiled
from asictl.il.crossref import LEGEND, entries, xref_text
from asictl.image.eeprom import HEADER_SIZE, ProgramImage
from asictl.mcs51.assembly import ListingEntry
from asictl.platform.master import EEPROM_SIZE
from asictl.runtime import layout
from asictl.runtime.firmware import FIRMWARE_BLOCKS
from asictl.runtime.program_map import CellKind, Location, ProgramMap, Space
from asictl.source import SourceText

#: The first words of every listing: how an existing file is recognised as one.
LISTING_MARK = "; asictl compile listing"
_BYTES_PER_ROW = 4
_IL_PREFIX = 20  # width of the LINE/BYTES/CYC columns before IL text


def listing_text(compiled: Compiled, image: ProgramImage) -> str:
    main = next(iter(compiled.program.sources))
    rows = [
        f"{LISTING_MARK} of {main}",
        f"; asictl {__version__}, program identity {image.identity_hex}",
        ";",
        ";  LINE BYTES  CYC  IL SOURCE (bytes and cycles: every instruction once)",
        ";                   ADDR  CODE         CYC  ASSEMBLY",
        "",
        *_code_rows(compiled),
        "",
        *image_summary(image),
        *cross_reference(compiled),
    ]
    return "\n".join(rows) + "\n"


def cross_reference(compiled: Compiled) -> list[str]:
    """The listing's last section: every operand with the lines that read and write it,
    and each variable with its address."""
    return [
        ";",
        "; ---- cross-reference",
        f"; {LEGEND}",
        *xref_text(entries(compiled.program, variables=compiled.pmap.variables), prefix="; "),
    ]


def raw_listing_text(name: str, image: ProgramImage) -> str:
    """The listing of an image read from [RAW] records: no IL to list, only the map."""
    rows = [
        f"{LISTING_MARK} of {name}",
        f"; asictl {__version__}, program identity {image.identity_hex}",
        "; the image comes from the [RAW] section: there is no IL source to list",
        "",
        *image_summary(image),
    ]
    return "\n".join(rows) + "\n"


# ----------------------------------------------------------------------- code


def _code_rows(compiled: Compiled) -> Iterator[str]:
    sources = {name: _lines(s) for name, s in compiled.program.sources.items()}
    entries = [e for e in compiled.assembly.listing if e.span.file == GENERATED]
    spans = [compiled.lines[e.span.line - 1].span for e in entries]
    last_entry = {span.file: i for i, span in enumerate(spans) if span is not None}
    printed: dict[str, int] = {}  # file -> last source line listed
    current_file = None
    i = 0
    while i < len(entries):
        span = spans[i]
        if span is None:  # generated without an IL line: entry, implicit BE, helpers
            if not entries[i].text.lstrip().startswith(";"):  # symbol values: see memory map
                yield from _asm_rows(entries[i])
            i += 1
            continue
        end = i + 1
        while (
            end < len(entries)
            and (following := spans[end]) is not None
            and (following.file, following.line) == (span.file, span.line)
        ):
            end += 1
        group = entries[i:end]
        source = sources.get(span.file, [])
        if span.file != current_file:
            current_file = span.file
            yield f"; ---- {span.file}"
        done = printed.get(span.file, 0)
        yield from (_il_row(source, n) for n in range(done + 1, span.line))
        yield _il_row(source, span.line, group)
        printed[span.file] = max(done, span.line)
        for entry in group:
            yield from _asm_rows(entry)
        if last_entry[span.file] < end:  # the file's last code: list its remaining lines
            yield from (_il_row(source, n) for n in range(printed[span.file] + 1, len(source) + 1))
            printed[span.file] = len(source)
        i = end


def _lines(source: SourceText) -> list[str]:
    lines = source.text.split("\n")
    return lines[:-1] if source.text.endswith("\n") else lines


def _il_row(source: list[str], number: int, code: Sequence[ListingEntry] = ()) -> str:
    text = source[number - 1].expandtabs(8) if number <= len(source) else ""
    size = sum(len(e.data) for e in code)
    cycles = sum(e.cycles or 0 for e in code)
    totals = f"{size:>5} {cycles:>4}" if size else " " * 10
    return f"{number:>7} {totals}  {text}".rstrip()


def _asm_rows(entry: ListingEntry) -> Iterator[str]:
    start = entry.address
    address = "    " if start is None else f"{start:04X}"
    cycles = "" if entry.cycles is None else str(entry.cycles)
    chunk = entry.data[:_BYTES_PER_ROW].hex(" ").upper()
    yield f"{'':{_IL_PREFIX}}{address}  {chunk:<12} {cycles:>3}  {entry.text}".rstrip()
    if start is not None:  # always so for a line with data
        for offset in range(_BYTES_PER_ROW, len(entry.data), _BYTES_PER_ROW):
            chunk = entry.data[offset : offset + _BYTES_PER_ROW].hex(" ").upper()
            yield f"{'':{_IL_PREFIX}}{start + offset:04X}  {chunk}"


# ----------------------------------------------------------------------- summaries


def _plural(count: int, word: str) -> str:
    return f"{count} {word}{'' if count == 1 else 's'}"


def _memory(location: Location) -> str:
    if location.space is Space.XDATA:
        return "XDATA"
    return "bit" if location.bit_addressable else "direct"


def cells_summary(pmap: ProgramMap) -> str:
    """Where the process-image bytes the program addresses went."""
    places = [_memory(location) for location in pmap.cells.values()]
    return (
        f"{_plural(len(places), 'cell')}: {places.count('bit')} in bit memory, "
        f"{places.count('direct')} direct, {places.count('XDATA')} in XDATA"
    )


def data_summary(pmap: ProgramMap) -> str:
    """The program's own data in external RAM."""
    return (
        f"{_plural(len(pmap.timers), 'timer')}, {_plural(len(pmap.counters), 'counter')}, "
        f"{_plural(len(pmap.variables), 'variable')}; XDATA {pmap.data_end - layout.DATA_BASE} "
        f"bytes at {layout.DATA_BASE:04X}h-{pmap.data_end - 1:04X}h"
    )


def image_size_summary(image: ProgramImage) -> str:
    """How the EEPROM is used, in one line."""
    size = len(image.to_bytes())
    program_map = size - HEADER_SIZE - len(image.code) - len(image.source)
    if image.source:
        source = f"source {len(image.source)}"
    else:
        source = "no source" + (" (did not fit)" if image.source_left_out else "")
    return (
        f"{size} bytes of {EEPROM_SIZE}: header {HEADER_SIZE}, code {len(image.code)}, "
        f"program map {program_map}, {source}"
    )


def code_summary(image: ProgramImage) -> str:
    end = image.code_base + len(image.code) - 1
    span = f" at {image.code_base:04X}h-{end:04X}h" if image.code else ""
    return f"{len(image.code)} bytes{span}"


def _cell_name(kind: CellKind, index: int) -> str:
    match kind:
        case CellKind.F:
            return f"FY {index}"
        case CellKind.TS:
            return f"timers {8 * index}-{8 * index + 7} status"
        case _:
            return f"{kind.value}B {2 * index} (slaves {2 * index}, {2 * index + 1})"


def image_summary(image: ProgramImage) -> list[str]:
    """The closing part of a listing: sizes, then every address the program uses."""
    pmap = image.pmap
    rows = [
        "; ---- summary",
        f"; code      {code_summary(image)}",
        f"; memory    {cells_summary(pmap)}",
        f"; data      {data_summary(pmap)}",
        f"; image     {image_size_summary(image)}",
        f"; identity  {image.identity_hex}",
        ";",
        "; ---- memory map",
    ]
    places = [
        (_cell_name(kind, index), f"{location.address:02X}h {_memory(location)}")
        for (kind, index), location in sorted(pmap.cells.items())
    ]
    places.append(("PSeg", f"{pmap.pseg:04X}h, 16 bytes"))
    places += [(f"T {n}", f"{address:04X}h") for n, address in sorted(pmap.timers.items())]
    places += [(f"C {n}", f"{address:04X}h") for n, address in sorted(pmap.counters.items())]
    places += [
        (v.name, f"{v.address:04X}h, {_plural(v.size, 'byte')}")
        for v in sorted(pmap.variables.values(), key=lambda v: v.address)
    ]
    places += [
        (f"firmware {FIRMWARE_BLOCKS[name].name}", f"{address:04X}h")
        for name, address in sorted(image.entry_points.items())
    ]
    width = max(len(name) for name, _ in places)
    rows += [f"; {name:<{width}}  {where}" for name, where in places]
    return rows
