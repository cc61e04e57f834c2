"""Forcing from the host: ``asictl force``, ``unforce``, the ``forced`` table of
``status`` and the monitor's force keys (docs/commissioning.md, "Forcing").

Operands are named as everywhere (``observe.operands``: ``"F 10.0=1"``, ``"FY 12=0x55"``,
``"Q 2=0b1010"``, ``"Motor=1"``) and turned into the board's force list entries (board/
forcing.py: an area, a slave or flag byte, a mask, bits) exactly as ``asictl write``
turns them into image changes (``host.commissioning.image_changes``). Only an emulated
board forces: a real PC2 board and a gateway are refused with ``NotForcing``, because
their firmware has no force list.

The list comes back from the board as entries per slave or flag byte (host/force_list.py
reads them and names them again as operands).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from asictl.board.forcing import Area
from asictl.errors import ExitCode, UserError
from asictl.host.commissioning import image_changes
from asictl.host.force_list import Entry, entries_from_json
from asictl.host.master import Master
from asictl.il.ast import OperandKind as K
from asictl.observe.operands import Assignment, Operand
from asictl.platform.master import SLAVES

#: The operand kinds a force takes, and the area each is in.
AREAS = {K.I: Area.INPUTS, K.IB: Area.INPUTS, K.Q: Area.OUTPUTS, K.QB: Area.OUTPUTS,
         K.F: Area.FLAGS, K.FY: Area.FLAGS}
#: What can be forced, as messages say it.
FORCEABLE = "inputs (I, IB), outputs (Q, QB) and flags (F, FY)"


class NotForcing(UserError):
    """The master has no force list (a real board, a gateway)."""

    exit_code = ExitCode.FAILED


def force_entries(assignment: Assignment) -> list[Entry]:
    """The force list entries of ``OPERAND=VALUE``; ``UserError`` (exit 2) for an
    operand that cannot be forced."""
    area = _area(assignment.operand, assignment.written)
    changes = image_changes(assignment)
    if area is not Area.FLAGS and not all(1 <= n < SLAVES for n, _, _ in changes):
        raise UserError(f"'{assignment.written}': slaves 1..31 have data bits", ExitCode.USAGE)
    return [(area, n, mask, bits) for n, mask, bits in changes]


def release_entries(operand: Operand, written: str = "") -> list[tuple[Area, int, int]]:
    """What releasing ``operand`` releases: [area, index, mask], the bits a force of it
    holds."""
    written = written or str(operand)
    area = _area(operand, written)
    return [(area, n, mask) for n, mask, _ in image_changes(Assignment(operand, 0, written))]


def _area(operand: Operand, written: str) -> Area:
    area = AREAS.get(operand.node.kind)
    if area is None:
        raise UserError(f"'{written}' cannot be forced: a force holds {FORCEABLE}",
                        ExitCode.USAGE)
    return area


def _board(master: Master) -> Any:
    if master.action is None:
        raise NotForcing(
            f"{master.name}: forcing is refused: the PC2 firmware has no force list, so "
            "only an emulated board (the default --io emulated, or 'asictl serve') forces"
        )
    return master.action


def force(master: Master, assignments: Sequence[Assignment]) -> list[Entry]:
    """Force all of ``assignments`` (all or none); the board's force list after it."""
    changes = [list(e) for a in assignments for e in force_entries(a)]
    return entries_from_json(_board(master).run("force", {"changes": changes}))


def unforce(
    master: Master, operands: Sequence[tuple[Operand, str]] | None
) -> tuple[int, list[Entry]]:
    """Release ``operands`` (operand, as written) or, for None, everything: how many
    forces were released, and the force list left."""
    if operands is None:
        args: dict[str, Any] = {"all": True}
    else:
        args = {"changes": [list(e) for o, w in operands for e in release_entries(o, w)]}
    answer = _board(master).run("unforce", args)
    return int(answer["released"]), entries_from_json(answer["forced"])


def not_forced(entries: Sequence[Entry], operands: Sequence[tuple[Operand, str]]) -> list[str]:
    """The operands (as written) of which no bit is in the force list ``entries``."""
    held = {(area, index): mask for area, index, mask, _ in entries}
    return [written for operand, written in operands
            if not any(held.get((area, index), 0) & mask
                       for area, index, mask in release_entries(operand, written))]


def forced(master: Master) -> list[Entry]:
    """The board's force list (refused, as ``force``, on a master without one)."""
    return entries_from_json(_board(master).run("forced", {}))
