"""What the live board's server and its clients say to each other, and where they meet.

Each message is a 4-byte big-endian length and that many bytes of UTF-8 JSON.
Requests: ``{"op": "hello"}``; ``{"op": "begin", "who": TEXT}`` / ``{"op": "end"}`` (a
session: the client has the board to itself until it ends or disconnects; a client kept
waiting first gets ``{"waiting": HOLDER}``); ``{"op": "io", "ops": [...]}`` with
``["w", OFFSET, [BYTE, ...]]`` and ``["r", OFFSET, COUNT]``, answered by ``{"ok": true,
"reads": [[BYTE, ...], ...]}``; ``{"op": "action", "name": NAME, "args": {...}}`` for the
emulated-only actions of ``host.emulated.actions`` (the cable, the set button, the program's
timers and counters, and ``lines``: the program's IL lines with their values in the
latest cycle, for which the board runs one cycle under line hooks and removes them
again), or those a server attached to the board adds (``LiveBoard.actions``: the
gateway's front panel); ``{"op": "changes", "since": SERIAL or null}`` for what clients
changed after the change numbered SERIAL (host.live.changes; null: none yet, from now
on), answered by ``{"ok": true, "changes": [[SERIAL, TIME, TEXT, WHO], ...], "next":
SERIAL}``. A failure is ``{"ok": false, "error": TEXT, "exit": CODE}``.

Register accesses are batched (writes wait until a read needs their effect, and a block
of data reads is one access with a count), so a download moves a 240-byte block per
request. One request may do only as much as a command ever needs (``MAX_ACCESSES``,
``MAX_TRANSFER``, ``MAX_COMMANDS``): the server answers a larger one with an error
instead of keeping every other client waiting while it runs.

Only the socket's owner talks to the board: the client checks the socket file's owner
and the serving process's user (``peer_uid``) before it sends anything, and the server
checks each connecting process's user.
"""

from __future__ import annotations

import json
import socket
import struct
from pathlib import Path
from typing import TYPE_CHECKING, Any

from asictl.errors import ExitCode, UserError
from asictl.host.transports.ports import port_name

if TYPE_CHECKING:
    # Only the servers' side reads from asyncio streams: a command's client does
    # without asyncio (and the ssl module it loads).
    import asyncio

#: The largest answer a client accepts (the ``lines`` action's answer is the largest).
MAX_MESSAGE = 1 << 20
#: The largest request the server reads: several times what the limits below take.
MAX_REQUEST = 64 * 1024
#: Register accesses in one request. The driver's largest batch is a block written or
#: read a page at a time (INDEX, PAGE, the data: three accesses a page), its command
#: after it; a whole DPRAM (four pages) is a dozen.
MAX_ACCESSES = 64
#: Register bytes read plus bytes written in one request: the whole DPRAM, 1 KB. A
#: download or upload moves 240 bytes a request, so a 16 KB EEPROM takes 69 requests.
MAX_TRANSFER = 1024
#: Commands (writes of a code to 1F0h) in one request: the driver issues one and reads
#: its acknowledge; each runs the board up to 200 ms of master time.
MAX_COMMANDS = 2
#: The length in front of each message.
LENGTH = struct.Struct(">I")

JSON = Any


def socket_path(directory: Path, base: int) -> Path:
    return directory / f"pc2-{port_name(base).lower()}.sock"


def encode(message: JSON) -> bytes:
    data = json.dumps(message, separators=(",", ":")).encode()
    return LENGTH.pack(len(data)) + data


def decode(data: bytes) -> JSON:
    """A message's JSON; ``ValueError`` if it is none (RecursionError for deep nesting is
    one too: a hostile peer must not reach the interpreter's stack limit)."""
    try:
        return json.loads(data.decode())
    except RecursionError:
        raise ValueError("nested too deeply") from None


def peer_uid(sock: socket.socket | None) -> int | None:
    """The user of the process at the other end of a Unix socket; None where the system
    cannot say (no ``SO_PEERCRED``: the socket file's owner and mode are the check)."""
    option = getattr(socket, "SO_PEERCRED", None)
    if sock is None or option is None:
        return None
    credentials = struct.Struct("3i")  # struct ucred: pid, uid, gid
    try:
        _pid, uid, _gid = credentials.unpack(
            sock.getsockopt(socket.SOL_SOCKET, option, credentials.size)
        )
    except OSError:
        return None
    return int(uid)


class ProtocolError(UserError):
    """The other end broke the protocol or went away."""

    exit_code = ExitCode.FAILED


async def read_message(
    reader: asyncio.StreamReader, *, limit: int = MAX_MESSAGE
) -> JSON | None:
    """The next message of a client; None when it went away or broke the framing (a
    message over ``limit``, bytes that are not JSON): the connection ends."""
    try:
        (length,) = LENGTH.unpack(await reader.readexactly(LENGTH.size))
        if length > limit:
            return None
        return decode(await reader.readexactly(length))
    except (EOFError, ConnectionError, ValueError):  # EOFError: asyncio.IncompleteReadError
        return None
