"""The program's listing as the image carries it: the main file, then each function-block
file under a header line of its own, each line marked whether it has code and with the
operand its values are of. The monitor's program view (monitor/program.py) and the web
page's (web/) show the same rows, each with its values from the latest cycle.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import PurePath

from asictl.build import program_of_image
from asictl.host.status import StoredProgram
from asictl.image.eeprom import ImageError, ProgramImage
from asictl.observe.iltrace import line_operands
from asictl.observe.online import NO_LINE_MAP
from asictl.runtime.line_map import SourceLine
from asictl.source import decode

NO_SOURCE = (
    "the source is not in the image (compiled with --no-source, or uploaded as [RAW]): "
    "the lines with code by number, without their operands"
)


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
