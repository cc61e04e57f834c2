"""The monitor's program view, apart from the screen: the program's source as the image
carries it, each line with its values from the latest cycle (STEP 7's "monitor block").

The listing (host/listing.py) is the main file, then each function-block file under a
header line of its own, so one scrollable list holds every line the program can run. Each
line with code shows the single-bit register (RLO), ACCU1, ACCU2, the constant register
(KREG) and the value of its operand as the line left them in the latest cycle (in hex on
request, as ASI_MON shows values); a line that did not run in it is grey with no values.
A line that loads a timer constant (``L KT``) shows it as a time too, since KREG holds
10 ms ticks.
An image without its source (``compile --no-source``, an uploaded [RAW] file) still has
its line map: the view lists the lines with code by number, with their values.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping

from rich.text import Text

from asictl.diagnostics import printable
from asictl.host.listing import Listing
from asictl.observe.online import CycleLines, LineValues
from asictl.readers.units import TICK_MS, format_duration

#: A line that loads a timer constant: its KREG is in 10 ms ticks, shown as a time too.
_LOADS_KT = re.compile(r"\bL\s+KT\b", re.IGNORECASE)

#: Columns of the values, right of the source.
VALUES_WIDTH = 37
MIN_SOURCE_WIDTH = 20


def source_width(listing: Listing, width: int) -> int:
    """The source column: as wide as the longest line, within ``width`` less the line
    numbers and the values."""
    longest = max((len(line.text or "") for line in listing.lines), default=0)
    return max(MIN_SOURCE_WIDTH, min(longest + 2, width - VALUES_WIDTH - 7))


def render_rows(
    listing: Listing, lines: CycleLines | None, *, top: int, height: int, width: int,
    stop_line: str | None = None, hex_values: bool = False,
    names: Mapping[str, str] | None = None,
) -> Text:
    """Rows ``top`` .. ``top + height`` of the listing, each with its values (in hex
    with ``hex_values``: ASI_MON shows hex) and its operand's name in ``names``
    (operand -> name, the board's symbol table). A file name, a comment or a name
    that holds control characters shows them escaped."""
    text = Text()
    columns = source_width(listing, width)
    for row in listing.lines[top : top + height]:
        if text:
            text.append("\n")
        if row.number == 0:
            label = f"── {printable(row.file, lines=False)} "
            text.append(label + "─" * max(0, width - len(label) - 1), style="bold cyan")
            continue
        stopped = stop_line == str(row.where)
        text.append(">>" if stopped else "  ", style="bold red" if stopped else "")
        values = None if lines is None else lines.lines.get(row.where)
        grey = row.code and values is not None and not values.ran
        text.append(f"{row.number:>4} ", style="dim")
        source = printable(row.text, lines=False) if row.text is not None else ""
        text.append(_fit(source, columns), style="dim" if grey or not row.code else "")
        if row.code and values is not None:
            _values(text, values, _hex if hex_values else str)
            if values.ran and values.constant is not None and _LOADS_KT.search(source):
                text.append(f"  KT {format_duration(values.constant * TICK_MS)}", style="dim")
        name = (names or {}).get(row.operand or "")
        if name and values is not None and values.ran and values.operand is not None:
            text.append(f" ({printable(name, lines=False)})", style="cyan")
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
        f"  {'line':>4} {source:<{source_width(listing, width)}}{'RLO':>4}{'ACCU1':>7}"
        f"{'ACCU2':>7}{'KREG':>7}  operand" + ("  (hex)" if hex_values else ""),
        style="bold",
    )
