"""What a client's request does to the live board: register accesses and actions.

Each client has its own INDEX/PAGE pointer, restored before its accesses, and a command
written to the command byte runs to its acknowledge before the request returns (the
board executes it at its next AS-i cycle, a few milliseconds of master time): no request
of another client, and no Modbus telegram, can come between.
"""

from __future__ import annotations

from collections.abc import Awaitable
from dataclasses import dataclass

from asictl.errors import ExitCode, UserError
from asictl.host.emulated import run_action
from asictl.host.live.board import LiveBoard
from asictl.host.live.protocol import JSON, MAX_MESSAGE, ProtocolError
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


def io(live: LiveBoard, pointer: Pointer, ops: JSON) -> list[list[int]]:
    """Register accesses in order, from this client's pointer; the board's own
    auto-increment moves it, and it is kept for the client's next request (also after a
    malformed access, as far as the accesses before it went)."""
    if not isinstance(ops, list):
        raise ProtocolError("'io' needs a list of accesses")
    board = live.board
    page_bits = PAGE_RESET_BIT if board.in_reset else 0
    board.io_write(PORT_INDEX, pointer.address & 0xFF)
    board.io_write(PORT_PAGE, pointer.address >> 8 | page_bits)
    try:
        return _accesses(live, ops)
    finally:
        pointer.address = board.pointer


def _accesses(live: LiveBoard, ops: list[JSON]) -> list[list[int]]:
    board = live.board
    reads: list[list[int]] = []
    for op in ops:
        if not (isinstance(op, list) and len(op) == 3 and op[1] in (0, 1, 2)):
            raise ProtocolError(f"malformed access {op!r}")
        kind, offset, arg = op
        if kind == "w" and isinstance(arg, list):
            for value in arg:
                _write(live, offset, value)
        elif kind == "r" and isinstance(arg, int) and 0 < arg <= MAX_MESSAGE // 4:
            reads.append([board.io_read(offset) for _ in range(arg)])
        else:
            raise ProtocolError(f"malformed access {op!r}")
    return reads


def _write(live: LiveBoard, offset: int, value: JSON) -> None:
    if not isinstance(value, int) or not 0 <= value <= 0xFF:
        raise ProtocolError(f"a register takes a byte, not {value!r}")
    board = live.board
    command = offset == PORT_DATA and board.pointer == COMMAND and value not in (ACK, NAK)
    board.io_write(offset, value)
    if command:
        live.run_command()


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


def action(live: LiveBoard, request: dict[str, JSON]) -> JSON:
    """One of ``host.emulated``'s actions, as the request names it (unless a debugger
    holding the board refuses it)."""
    name, args = request.get("name"), request.get("args") or {}
    if not isinstance(name, str) or not isinstance(args, dict):
        raise ProtocolError("an action needs a name and arguments")
    refusal = live.hold.refusal(name) if live.hold is not None else None
    if refusal is not None:
        raise UserError(refusal, ExitCode.FAILED)
    return run_action(live.board, name, args)
