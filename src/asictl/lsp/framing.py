"""The editor protocols' base protocol: JSON messages in ``Content-Length`` frames.

The Debug Adapter Protocol and the Language Server Protocol frame their messages alike:
a header block (``Content-Length: N``, other headers ignored, a blank line) and N bytes
of UTF-8 JSON, nothing more. ``dap`` and ``lsp`` both read them here rather than with a
library (pygls's reader, for one, loses every later message after one frame without a
length), because what no library gives is the robustness an editor's client can rely
on: nothing a client sends crashes or wedges the server. A frame with no or a bad
``Content-Length``, a body that is not a JSON object, or one larger than the reader's
``max_body`` is reported (``Malformed``) and skipped; the reader then looks for the next
header line, so it never waits for the bytes a huge length announces and never holds
more than one line of ``MAX_LINE`` bytes of a message it will not read.
"""

from __future__ import annotations

import json
import threading
from dataclasses import dataclass
from typing import Any, BinaryIO

JSON = Any

#: The largest message body the debug adapter reads (DAP messages are a few kilobytes).
MAX_BODY = 1 << 20
#: Header lines (and the lines of skipped text) are read at most this long at a time.
MAX_LINE = 4096
_LENGTH = b"content-length"


@dataclass(frozen=True)
class Malformed:
    """A frame the reader skipped, and why (for the client's console)."""

    why: str


class Reader:
    """Reads messages from a byte stream; ``read()`` is None at its end."""

    def __init__(self, stream: BinaryIO, *, max_body: int = MAX_BODY) -> None:
        self.stream = stream
        self.max_body = max_body

    def read(self) -> dict[str, JSON] | Malformed | None:
        length = self._header()
        if length is None:
            return None
        if isinstance(length, Malformed):
            return length
        body = self.stream.read(length)
        if len(body) < length:
            return None  # the stream ended inside the body
        try:
            message = json.loads(body)
        except (ValueError, RecursionError) as exc:  # UnicodeDecodeError is a ValueError
            return Malformed(f"the body is not JSON ({type(exc).__name__})")
        if not isinstance(message, dict):
            return Malformed("the body is not a JSON object")
        return message

    def _header(self) -> int | Malformed | None:
        """The length of the next frame's body. Lines that are not a length header (other
        headers, text where a header belongs, a skipped body) are passed over; a header
        glued to the end of a skipped body still counts."""
        length: int | Malformed | None = None
        while True:
            line = self.stream.readline(MAX_LINE)
            if not line:
                return None
            text = line.strip()
            if not text:
                if length is not None:
                    return length
                continue
            at = text.lower().find(_LENGTH + b":")
            if at >= 0:
                length = self._length(text[at + len(_LENGTH) + 1 :].strip())

    def _length(self, value: bytes) -> int | Malformed:
        if not value.isdigit():
            return Malformed(f"Content-Length {value[:40]!r} is not a number")
        length = int(value)
        if length > self.max_body:
            return Malformed(f"a message of {length} bytes is larger than the "
                             f"{self.max_body} this adapter reads; skipped")
        return length


class Writer:
    """Writes messages to a byte stream, one at a time from any thread."""

    def __init__(self, stream: BinaryIO) -> None:
        self.stream = stream
        self._lock = threading.Lock()
        #: the stream broke (the client went away): further messages are dropped
        self.closed = False

    def write(self, message: JSON) -> None:
        body = json.dumps(message, separators=(",", ":")).encode("utf-8")
        with self._lock:
            if self.closed:
                return
            try:
                self.stream.write(b"Content-Length: %d\r\n\r\n" % len(body) + body)
                self.stream.flush()
            except (OSError, ValueError):  # a closed pipe or file
                self.closed = True
