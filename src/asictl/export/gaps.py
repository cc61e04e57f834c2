"""What has no equivalent on another PLC, said once for every export language.

The master's firmware blocks and PARAM talk to the AS-i master itself, [ASSEMBLY] lines
are 8051 code: an export marks each where it stood and lists it as ``FILE:LINE: ...``
(docs/migrate.md), so that a person finishes the job with the new master's interface.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

from asictl.il import ast
from asictl.il.loader import Program
from asictl.il.pragmas import read_directives


@dataclass(frozen=True)
class Unfinished:
    """A construct without an equivalent: left for a person, with its source place."""

    file: str
    line: int
    what: str

    def __str__(self) -> str:
        return f"{self.file}:{self.line}: {self.what}"


def gap(statement: ast.Statement | ast.GatingLine, user_blocks: set[str]) -> str | None:
    """Why a statement has no equivalent, or None when it has one. ``user_blocks``: the
    key()s of the program's own function blocks (any other call is the firmware's)."""
    if isinstance(statement, ast.Param):
        return ("PARAM sends a parameter to a slave through the AS-i master: no "
                "equivalent (use the new AS-i master's interface, e.g. ASI_CTRL on an S7)")
    if isinstance(statement, ast.Asm):
        return "an [ASSEMBLY] line is 8051 code: no equivalent"
    if isinstance(statement, ast.CallFB) and ast.key(statement.name) not in user_blocks:
        return (f"the firmware block {statement.name} talks to the AS-i master: no "
                "equivalent (use the new AS-i master's interface)")
    return None


def host_flags(program: Program, where: Callable[[ast.Operand], str]) -> Iterator[Unfinished]:
    """The flags the program says a host writes (``; asictl: host F 10.0``): whatever
    wrote them on the master (a PC, a Modbus gateway, a panel) must be connected to
    ``where(flag)`` on the new PLC."""
    for flag, span in read_directives(program.sources).host_flags:
        yield Unfinished(span.file, span.line, f"{flag} is written by the host (a PC, a Modbus "
                         f"gateway, a panel): connect that writer to {where(flag)}")


def unfinished(statement: ast.Statement, why: str, file: str) -> Unfinished:
    """The entry of the list for a statement left for a person."""
    span = statement.span
    return Unfinished(span.file if span else file, span.line if span else 0,
                      f"{statement.to_source()}: {why}")


def il_comment(statement: ast.Statement | ast.GatingLine) -> str:
    """``FILE:LINE: text``, the IL line a translation stands for ('' for ``***``)."""
    if isinstance(statement, ast.SegmentEnd):
        return ""
    span = statement.span
    where = f"{span.file}:{span.line}: " if span else ""
    return f"{where}{statement.to_source()}"
