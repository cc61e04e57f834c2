"""The ``Content-Length`` frames of the editor protocols (LSP, DAP) for the test clients
(imported explicitly: ``from jsonrpc_framing import framed, read_messages``).

Written once for both clients, and on purpose independent of ``asictl.lsp.framing``, which
the servers read with: a server's frames are checked by a reader that is not its own.
This one is strict, as an editor is: a frame it cannot read fails the test.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any, BinaryIO


def frame(body: bytes) -> bytes:
    """``body`` in one frame."""
    return b"Content-Length: %d\r\n\r\n" % len(body) + body


def framed(content: dict[str, Any]) -> bytes:
    """A JSON message in one frame."""
    return frame(json.dumps(content).encode("utf-8"))


def read_messages(stream: BinaryIO, deliver: Callable[[dict[str, Any]], None]) -> None:
    """Hand each message of ``stream`` to ``deliver`` until the stream ends."""
    while True:
        headers: dict[str, str] = {}
        while True:
            line = stream.readline()
            if not line:
                return
            if line in (b"\r\n", b"\n"):
                break
            name, _, value = line.decode("ascii").partition(":")
            headers[name.strip().lower()] = value.strip()
        length = int(headers["content-length"])
        body = stream.read(length)
        if len(body) < length:
            return
        deliver(json.loads(body))
