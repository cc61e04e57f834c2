"""Reading Intel HEX files given to ``disasm`` and ``emu``, whatever the file really is.

A binary given by mistake, a device or a file cut short must end in a plain message,
never a traceback: the bytes are read with a bound (``MAX_HEX_BYTES``), must be ASCII,
and a file without an end-of-file record is read with a warning (a HEX file's last
record is what tells a complete file from a truncated one).
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path

from intelhex import IntelHex, IntelHexError

from asictl.errors import UserError
from asictl.source import read_bounded

#: A HEX file of the whole 64 KB 8051 code space in 1-byte records is about 850 KB.
MAX_HEX_BYTES = 2 * 1024 * 1024
_END_RECORD_TYPE = "01"


@dataclass
class HexFile:
    image: IntelHex
    warnings: list[str] = field(default_factory=list)


def read_hex(path: str | Path) -> HexFile:
    """The Intel HEX file at ``path`` ('-' is standard input); malformed is a ``UserError``."""
    name = "<stdin>" if str(path) == "-" else str(path)
    raw = read_bounded(path, MAX_HEX_BYTES, "an Intel HEX file")
    try:
        text = raw.decode("ascii")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise UserError(
            f"{name}: not a valid Intel HEX file: byte {raw[exc.start]:02X}h on line {line} "
            "is not text"
        ) from None
    try:
        image = IntelHex(io.StringIO(text))
    except IntelHexError as exc:
        raise UserError(f"{name}: not a valid Intel HEX file: {exc}") from None
    warnings = []
    if not any(_is_end_record(line) for line in text.splitlines()):
        warnings.append(
            f"{name}: no end-of-file record (:00000001FF); the file may be cut short"
        )
    return HexFile(image, warnings)


def _is_end_record(line: str) -> bool:
    record = line.strip()
    return record.startswith(":") and record[7:9] == _END_RECORD_TYPE
