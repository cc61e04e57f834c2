"""The monitor's program view, apart from the screen: the program's source as the image
carries it, each line with its values from the latest cycle (STEP 7's "monitor block").

The listing is the main file, then each function-block file under a header line of its
own, so one scrollable list holds every line the program can run. Each line with code
shows the single-bit register (RLO), ACCU1, ACCU2, the constant register (KREG) and the
value of its operand as the line left them in the latest cycle (in hex on request, as
ASI_MON shows values); a line that did not run in it is grey with no
values. An image without its source (``compile --no-source``, an uploaded [RAW] file)
still has its line map: the view lists the lines with code by number, with their values.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import PurePath

from rich.text import Text

from asictl.build import program_of_image
from asictl.host.status import StoredProgram
from asictl.image.eeprom import ImageError, ProgramImage
from asictl.observe.iltrace import line_operands
from asictl.observe.online import NO_LINE_MAP, CycleLines, LineValues
from asictl.runtime.line_map import SourceLine
from asictl.source import decode

NO_SOURCE = (
    "the source is not in the image (compiled with --no-source, or uploaded as [RAW]): "
    "the lines with code by number, without their operands"
)
#: Columns of the values, right of the source.
VALUES_WIDTH = 37
MIN_SOURCE_WIDTH = 20


@dataclass(frozen=True)
class ListedLine:
    """One row of the listing: a file's header (``number`` 0) or one of its lines."""

    file: str
    number: int
    #: the line's text (None: the image has no source; "" for a header)
    text: str | None
    #: the line has code, so it can have values
    code: bool = False
    #: the operand its value is of, as it prints ("Q 17.3"), to name it by the symbols
    operand: str | None = None

    @property
    def where(self) -> SourceLine:
        return SourceLine(self.file, self.number)


@dataclass(frozen=True)
class Listing:
    lines: tuple[ListedLine, ...] = ()
    #: what the view cannot show, in words ("" when it shows everything)
    note: str = ""

    def headers(self) -> list[int]:
        """The rows where a file starts."""
        return [i for i, line in enumerate(self.lines) if line.number == 0]

    @property
    def files(self) -> list[str]:
        return [line.file for line in self.lines if line.number == 0]

    def source_width(self, width: int) -> int:
        """The source column: as wide as the longest line, within ``width`` less the
        line numbers and the values."""
        longest = max((len(line.text or "") for line in self.lines), default=0)
        return max(MIN_SOURCE_WIDTH, min(longest + 2, width - VALUES_WIDTH - 7))


def listing_of(program: StoredProgram | None) -> Listing:
    """The listing of the EEPROM's image: its source, or its line map's lines."""
    if program is None:
        return Listing(note="the program image is being read")
    image = program.image
    if image is None:
        return Listing(note=f"no program to show: {program.info.problem or 'no image'}")
    with_code = set(image.line_map.lines())
    try:
        sources = image.program_sources()
    except ImageError as exc:
        sources, damaged = {}, str(exc)
    else:
        damaged = ""
    rows: list[ListedLine] = []
    if sources:
        operands = _operands(image)
        for name, raw in sources.items():
            file = PurePath(name).name
            rows.append(ListedLine(file, 0, ""))
            for number, text in enumerate(decode(raw).split("\n"), 1):
                where = SourceLine(file, number)
                rows.append(ListedLine(
                    file, number, text.expandtabs(8), where in with_code, operands.get(where)
                ))
        if rows and rows[-1].text == "" and rows[-1].number:  # the final line end
            rows.pop()
    else:
        for file in image.line_map.files:
            rows.append(ListedLine(file, 0, ""))
            rows.extend(
                ListedLine(file, line.line, None, True)
                for line in sorted(with_code) if line.file == file
            )
    notes = []
    if not image.line_map:
        notes.append(NO_LINE_MAP)
    if not sources:
        notes.append(damaged or NO_SOURCE)
    return Listing(tuple(rows), "; ".join(notes))


def _operands(image: ProgramImage) -> dict[SourceLine, str]:
    """Each line's operand as it prints (what the symbol table names); none from a
    source that does not read."""
    try:
        found = line_operands(program_of_image(image))
    except ImageError:
        return {}
    return {line: str(operand) for line, operand in found.items()}


def render_rows(
    listing: Listing, lines: CycleLines | None, *, top: int, height: int, width: int,
    stop_line: str | None = None, hex_values: bool = False,
    names: Mapping[str, str] | None = None,
) -> Text:
    """Rows ``top`` .. ``top + height`` of the listing, each with its values (in hex
    with ``hex_values``: ASI_MON shows hex) and its operand's name in ``names``
    (operand -> name, the board's symbol table)."""
    text = Text()
    source_width = listing.source_width(width)
    for row in listing.lines[top : top + height]:
        if text:
            text.append("\n")
        if row.number == 0:
            label = f"── {row.file} "
            text.append(label + "─" * max(0, width - len(label) - 1), style="bold cyan")
            continue
        stopped = stop_line == str(row.where)
        text.append(">>" if stopped else "  ", style="bold red" if stopped else "")
        values = None if lines is None else lines.lines.get(row.where)
        grey = row.code and values is not None and not values.ran
        text.append(f"{row.number:>4} ", style="dim")
        source = row.text if row.text is not None else ""
        text.append(_fit(source, source_width), style="dim" if grey or not row.code else "")
        if row.code and values is not None:
            _values(text, values, _hex if hex_values else str)
        name = (names or {}).get(row.operand or "")
        if name and values is not None and values.ran and values.operand is not None:
            text.append(f" ({name})", style="cyan")
    return text


def _fit(text: str, width: int) -> str:
    return text[: width - 1] + "…" if len(text) > width else text.ljust(width)


def _hex(value: int) -> str:
    return f"{value:X}h"


def _values(text: Text, values: LineValues, shown: Callable[[int], str]) -> None:
    if not values.ran:
        text.append(f"{'-':>4}{'-':>7}{'-':>7}{'-':>7}  not run", style="dim")
        return
    text.append(f"{values.rlo:>4}", style="bold green" if values.rlo else "bold")
    accu1, accu2 = shown(values.accu1 or 0), shown(values.accu2 or 0)
    text.append(f"{accu1:>7}{accu2:>7}{shown(values.constant or 0):>7}")
    if values.operand is not None:
        text.append(f"  {shown(values.operand)}", style="cyan")
    if values.runs > 1:
        text.append(f"  (ran {values.runs}x)", style="dim")


def heading(listing: Listing, width: int, *, hex_values: bool = False) -> Text:
    """The column titles above the rows (KREG: the constant register)."""
    source = "source" if any(line.text for line in listing.lines) else ""
    return Text(
        f"  {'line':>4} {source:<{listing.source_width(width)}}{'RLO':>4}{'ACCU1':>7}"
        f"{'ACCU2':>7}{'KREG':>7}  operand" + ("  (hex)" if hex_values else ""),
        style="bold",
    )
