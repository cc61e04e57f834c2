"""What a client's request does to the live board: register accesses and actions.

Each client has its own INDEX/PAGE pointer, restored before its accesses, and a command
written to the command byte runs to its acknowledge before the request returns (the
board executes it at its next AS-i cycle, a few milliseconds of master time): no request
of another client, and no Modbus telegram, can come between. So that no request keeps
the others waiting long, a request is checked against the protocol's limits before any of
its accesses runs (its commands are counted as they come: whether a write is a command
depends on where the pointer has got to).
"""

from __future__ import annotations

from collections.abc import Awaitable
from dataclasses import dataclass

from asictl.errors import ExitCode, UserError
from asictl.host.emulated.actions import VIEWS, run_action
from asictl.host.live.board import LiveBoard
from asictl.host.live.changes import action_change, action_refused
from asictl.host.live.protocol import (
    JSON,
    MAX_ACCESSES,
    MAX_COMMANDS,
    MAX_TRANSFER,
    ProtocolError,
)
from asictl.platform.pc2 import (
    ACK,
    COMMAND,
    NAK,
    PAGE_RESET_BIT,
    PORT_DATA,
    PORT_INDEX,
    PORT_PAGE,
)


@dataclass(eq=False)
class Pointer:
    """Where a client's INDEX/PAGE point, kept between its requests."""

    address: int = 0


def io(live: LiveBoard, pointer: Pointer, ops: JSON, who: str) -> list[list[int]]:
    """Register accesses in order, from this client's pointer; the board's own
    auto-increment moves it, and it is kept for the client's next request (also after a
    malformed access, as far as the accesses before it went). The changes they make are
    noted as ``who``'s."""
    accesses = _checked(ops)
    board = live.board
    page_bits = PAGE_RESET_BIT if board.in_reset else 0
    board.io_write(PORT_INDEX, pointer.address & 0xFF)
    board.io_write(PORT_PAGE, pointer.address >> 8 | page_bits)
    try:
        return _accesses(live, accesses, who)
    finally:
        pointer.address = board.pointer


class RequestTooLarge(ProtocolError):
    """A request beyond what one may do at a time."""


def _checked(ops: JSON) -> list[tuple[str, int, JSON]]:
    """The accesses of a request, each well-formed, together within the limits."""
    if not isinstance(ops, list):
        raise ProtocolError("'io' needs a list of accesses")
    if len(ops) > MAX_ACCESSES:
        raise RequestTooLarge(
            f"a request of {len(ops)} register accesses: at most {MAX_ACCESSES} at a time"
        )
    accesses, transfer = [], 0
    for op in ops:
        if not (isinstance(op, list) and len(op) == 3 and op[1] in (0, 1, 2)):
            raise ProtocolError(f"malformed access {op!r}")
        kind, offset, arg = op
        if kind == "w" and isinstance(arg, list):
            transfer += len(arg)
        elif kind == "r" and isinstance(arg, int) and not isinstance(arg, bool) and arg > 0:
            transfer += arg
        else:
            raise ProtocolError(f"malformed access {op!r}")
        accesses.append((kind, offset, arg))
    if transfer > MAX_TRANSFER:
        raise RequestTooLarge(
            f"a request reading and writing {transfer} register bytes: at most "
            f"{MAX_TRANSFER} at a time (the whole DPRAM)"
        )
    return accesses


def _accesses(
    live: LiveBoard, accesses: list[tuple[str, int, JSON]], who: str
) -> list[list[int]]:
    board = live.board
    reads: list[list[int]] = []
    commands = 0
    for kind, offset, arg in accesses:
        if kind == "r":
            reads.append([board.io_read(offset) for _ in range(arg)])
            continue
        for value in arg:
            if not isinstance(value, int) or not 0 <= value <= 0xFF:
                raise ProtocolError(f"a register takes a byte, not {value!r}")
            command = offset == PORT_DATA and board.pointer == COMMAND and value not in (
                ACK, NAK
            )
            if command and commands == MAX_COMMANDS:
                raise RequestTooLarge(f"more than {MAX_COMMANDS} commands in one request")
            if offset == PORT_DATA:
                live.before_write(board.pointer, value, who)
            board.io_write(offset, value)
            if command:
                commands += 1
                live.run_command(who)
    return reads


def attached_action(live: LiveBoard, request: dict[str, JSON]) -> Awaitable[JSON] | None:
    """The action a server attached to the board runs for this request (the gateway's
    front panel), if it has one of that name."""
    name, args = request.get("name"), request.get("args") or {}
    attached = live.actions.get(name) if isinstance(name, str) else None
    if attached is None:
        return None
    if not isinstance(args, dict):
        raise ProtocolError("an action needs a name and arguments")
    return attached(args)


def action(live: LiveBoard, request: dict[str, JSON], who: str) -> JSON:
    """One of the actions of ``host.emulated.actions``, as the request names it (unless a
    debugger holding the board refuses it, or holds it halted and the action would
    change it); one that changes the board is noted as ``who``'s. The view says what
    holds the board halted (``held``)."""
    name, args = request.get("name"), request.get("args") or {}
    if not isinstance(name, str) or not isinstance(args, dict):
        raise ProtocolError("an action needs a name and arguments")
    refusal = live.hold.refusal(name) if live.hold is not None else None
    if refusal is not None:
        raise UserError(refusal, ExitCode.FAILED)
    if name not in VIEWS and live.halted() is not None:
        live.refuse_change(action_refused(live.board, name, args))
    result = run_action(live.board, name, args)
    if name == "view":
        result["held"] = live.halted()
    elif name not in VIEWS:
        live.changes.note(action_change(live.board, name, args), who)
    return result
