"""``--port`` and ``--io``: which PC2 board a command means, and how it is reached.

A board is named by its I/O base, as the manual's tools name it (``300h``), whether it is
a real board reached through /dev/port or an emulated one kept in the state directory.
"""

from __future__ import annotations

from asictl.errors import UserError
from asictl.platform.pc2 import IO_BASES

#: ``--io``: an emulated board, or a real one through /dev/port.
IO_BACKENDS = ("emulated", "devport")


def parse_port(text: str) -> int:
    """An I/O base as the manual writes it: ``300h``; also ``0x300`` and ``300`` (hex)."""
    digits = text.strip().lower()
    if digits.startswith("0x"):
        digits = digits[2:]
    elif digits.endswith("h"):
        digits = digits[:-1]
    try:
        base = int(digits, 16)
    except ValueError:
        base = -1
    if base not in IO_BASES:
        raise UserError(
            f"port '{text}': a PC2 board sits at "
            + ", ".join(port_name(b) for b in IO_BASES)
        )
    return base


def port_name(base: int) -> str:
    return f"{base:X}h"
