"""What the live board's server and its clients say to each other, and where they meet.

Each message is a 4-byte big-endian length and that many bytes of UTF-8 JSON.
Requests: ``{"op": "hello"}``; ``{"op": "begin", "who": TEXT}`` / ``{"op": "end"}`` (a
session: the client has the board to itself until it ends or disconnects; a client kept
waiting first gets ``{"waiting": HOLDER}``); ``{"op": "io", "ops": [...]}`` with
``["w", OFFSET, [BYTE, ...]]`` and ``["r", OFFSET, COUNT]``, answered by ``{"ok": true,
"reads": [[BYTE, ...], ...]}``; ``{"op": "action", "name": NAME, "args": {...}}`` for the
emulated-only actions of ``host.emulated`` (the cable, the set button, the program's
timers and counters, and ``lines``: the program's IL lines with their values in the
latest cycle, for which the board runs one cycle under line hooks and removes them
again), or those a server attached to the board adds (``LiveBoard.actions``: the
gateway's front panel). A failure is ``{"ok": false, "error": TEXT, "exit": CODE}``.

Register accesses are batched (writes wait until a read needs their effect, and a block
of data reads is one access with a count), so a download moves a 240-byte block per
request.
"""

from __future__ import annotations

import asyncio
import json
import struct
from pathlib import Path
from typing import Any

from asictl.errors import ExitCode, UserError
from asictl.host.boards import port_name

#: The largest message either side accepts.
MAX_MESSAGE = 1 << 20
#: The length in front of each message.
LENGTH = struct.Struct(">I")

JSON = Any


def socket_path(directory: Path, base: int) -> Path:
    return directory / f"pc2-{port_name(base).lower()}.sock"


def encode(message: JSON) -> bytes:
    data = json.dumps(message, separators=(",", ":")).encode()
    return LENGTH.pack(len(data)) + data


def decode(data: bytes) -> JSON:
    return json.loads(data.decode())


class ProtocolError(UserError):
    """The other end broke the protocol or went away."""

    exit_code = ExitCode.FAILED


async def read_message(reader: asyncio.StreamReader) -> JSON | None:
    """The next message of a client; None when it went away or broke the framing (a
    message over ``MAX_MESSAGE``, bytes that are not JSON): the connection ends."""
    try:
        (length,) = LENGTH.unpack(await reader.readexactly(LENGTH.size))
        if length > MAX_MESSAGE:
            return None
        return decode(await reader.readexactly(length))
    except (asyncio.IncompleteReadError, ConnectionError, ValueError):
        return None
