"""The commands' end of the live board: finding it, talking to it, driving it.

``open_live`` finds the socket (and removes one a dead server left behind);
``LiveClient`` sends requests and waits for their answers; ``LivePort`` is the
``PortIO`` the commands' driver runs on, batching its register accesses into requests.
"""

from __future__ import annotations

import contextlib
import socket
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from asictl.errors import ExitCode, UserError
from asictl.host.boards import lock_file, port_name
from asictl.host.emulated import SETTLE_MS, VIEWS
from asictl.host.live.protocol import JSON, LENGTH, ProtocolError, decode, encode, socket_path
from asictl.host.locking import is_free
from asictl.platform.pc2 import PORT_DATA

#: How long a client waits for an answer (a session may wait longer: it is announced).
ANSWER_TIMEOUT_S = 30.0


class LiveClient:
    """A connection to a live board; requests are answered in order."""

    def __init__(self, sock: socket.socket, path: Path) -> None:
        self.sock = sock
        self.path = path
        self.server: dict[str, JSON] = {}

    def _send(self, message: JSON) -> None:
        try:
            self.sock.sendall(encode(message))
        except OSError as exc:
            raise ProtocolError(f"{self.path}: the live board went away ({exc})") from None

    def _receive(self, timeout: float | None = ANSWER_TIMEOUT_S) -> JSON:
        self.sock.settimeout(timeout)
        try:
            head = self._exactly(LENGTH.size)
            (length,) = LENGTH.unpack(head)
            return decode(self._exactly(length))
        except TimeoutError:
            raise ProtocolError(f"{self.path}: the live board did not answer") from None
        except OSError as exc:
            raise ProtocolError(f"{self.path}: the live board went away ({exc})") from None

    def _exactly(self, size: int) -> bytes:
        data = b""
        while len(data) < size:
            chunk = self.sock.recv(size - len(data))
            if not chunk:
                raise ProtocolError(f"{self.path}: the live board went away")
            data += chunk
        return data

    def request(self, message: JSON) -> JSON:
        self._send(message)
        return self._answer(self._receive())

    @staticmethod
    def _answer(answer: JSON) -> JSON:
        if not isinstance(answer, dict) or not answer.get("ok"):
            error = answer.get("error", "malformed answer") if isinstance(answer, dict) else ""
            code = answer.get("exit", 1) if isinstance(answer, dict) else 1
            raise UserError(str(error), ExitCode(code) if code in (1, 2) else ExitCode.FAILED)
        return answer

    def hello(self) -> dict[str, JSON]:
        server = self.request({"op": "hello"}).get("server", {})
        self.server = server if isinstance(server, dict) else {}
        return self.server

    @contextmanager
    def session(self, who: str, waiting: Callable[[str], None] | None = None) -> Iterator[None]:
        """The board to this client alone; ``waiting`` hears who has it meanwhile."""
        self._send({"op": "begin", "who": who})
        answer = self._receive()
        if isinstance(answer, dict) and "waiting" in answer:
            if waiting is not None:
                waiting(str(answer["waiting"]))
            answer = self._receive(timeout=None)
        self._answer(answer)
        try:
            yield
        finally:
            with contextlib.suppress(UserError):
                self.request({"op": "end"})

    def io(self, ops: list[JSON]) -> list[list[int]]:
        reads = self.request({"op": "io", "ops": ops})["reads"]
        assert isinstance(reads, list)
        return reads

    def action(self, name: str, **args: JSON) -> JSON:
        return self.request({"op": "action", "name": name, "args": args})["result"]

    def close(self) -> None:
        self.sock.close()


class LivePort:
    """``PortIO`` over a ``LiveClient``: writes wait for the next read, which takes them
    along; ``read_data`` reads a run of data bytes in one access."""

    def __init__(self, client: LiveClient) -> None:
        self.client = client
        self._pending: list[JSON] = []

    def write(self, offset: int, value: int) -> None:
        last = self._pending[-1] if self._pending else None
        if last is not None and last[1] == offset and offset == PORT_DATA:
            last[2].append(value & 0xFF)
        else:
            self._pending.append(["w", offset, [value & 0xFF]])

    def _read(self, offset: int, count: int) -> list[int]:
        ops, self._pending = [*self._pending, ["r", offset, count]], []
        return self.client.io(ops)[-1]

    def read(self, offset: int) -> int:
        return self._read(offset, 1)[0]

    def read_data(self, count: int) -> bytes:
        return bytes(self._read(PORT_DATA, count))

    def flush(self) -> None:
        if self._pending:
            ops, self._pending = self._pending, []
            self.client.io(ops)

    def now_ms(self) -> float:
        return time.monotonic() * 1000.0


def open_live(directory: Path, base: int) -> LiveClient | None:
    """The live board at ``base`` if one serves it; a socket left behind by a server that
    died is removed (only when the board's lock is free: a starting server keeps its)."""
    path = socket_path(directory, base)
    if not path.exists():
        return None
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.connect(str(path))
    except (ConnectionRefusedError, FileNotFoundError):
        sock.close()
        if is_free(lock_file(directory, base)):  # so no live board can be serving it
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
        return None
    except PermissionError:
        sock.close()
        raise UserError(
            f"{path}: a live board serves port {port_name(base)} but this user may not "
            "talk to it (the socket belongs to its owner)"
        ) from None
    except OSError as exc:
        sock.close()
        raise UserError(f"{path}: cannot reach the live board: {exc.strerror or exc}") from None
    client = LiveClient(sock, path)
    client.hello()
    return client


def is_served(directory: Path, base: int) -> bool:
    client = open_live(directory, base)
    if client is None:
        return False
    client.close()
    return True


def refuse_if_served(directory: Path, base: int) -> None:
    """A second server for one board would wait on its lock forever: say who serves it."""
    client = open_live(directory, base)
    if client is not None:
        server = client.server
        client.close()
        raise UserError(
            f"board {port_name(base)} is already served live by "
            f"{server.get('command', 'another process')} (pid {server.get('pid', '?')})",
            ExitCode.FAILED,
        )


def served_by(client: LiveClient) -> str:
    server = client.server
    return f"{server.get('command', 'a live board')} (pid {server.get('pid', '?')})"


@dataclass(frozen=True)
class LiveActions:
    """``EmulatedBoard`` for a live board, through its socket. It runs on by itself:
    after a change the command waits as long as a board loaded from its state file would
    run on (``SETTLE_MS``), so its report shows the effect too."""

    client: LiveClient

    @property
    def live(self) -> str:
        return served_by(self.client)

    def run(self, name: str, args: dict[str, JSON]) -> JSON:
        result = self.client.action(name, **args)
        if name not in VIEWS:
            self.settle()
        return result

    def settle(self) -> None:
        time.sleep(SETTLE_MS / 1000)

    def wait_ms(self, ms: float) -> None:
        time.sleep(ms / 1000)
