"""The commands' end of the live board: finding it, talking to it, driving it.

``open_live`` finds the socket (and removes one a dead server left behind), and talks
to it only if it is the user's own: a socket file of another user, or a serving process
of another user, is refused before a request is sent, since a socket planted in the
state folder would take the user's download to someone else's board. ``LiveClient``
sends requests and waits for their answers, each checked for the form it must have (an
answer that is not the protocol's is a plain error, never a crash); ``LivePort`` is the
``PortIO`` the commands' driver runs on, batching its register accesses into requests.
"""

from __future__ import annotations

import contextlib
import os
import select
import socket
import stat
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from asictl.errors import ExitCode, UserError
from asictl.host.emulated.actions import NEXT_CYCLE, SETTLE_MS, VIEWS
from asictl.host.emulated.boards import lock_file
from asictl.host.emulated.locking import is_free
from asictl.host.emulated.state_files import UnsafeStateFolder, check_folder
from asictl.host.live.changes import Change
from asictl.host.live.protocol import (
    JSON,
    LENGTH,
    MAX_MESSAGE,
    ProtocolError,
    decode,
    encode,
    peer_uid,
    socket_path,
)
from asictl.host.transports.ports import port_name
from asictl.platform.pc2 import IO_BASES, PORT_DATA

#: How long a client waits for an answer (a session may wait longer: it is announced).
ANSWER_TIMEOUT_S = 30.0
#: A wait for the board this short is not announced: a monitor's refresh holds it for a
#: few milliseconds at a time, and a command behind it should not say so. (Half of the
#: shortest session time-out a test sets, 1 s, so a wait that long is still heard.)
QUIET_WAIT_S = 0.5


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
            raise self._parting_words() or ProtocolError(
                f"{self.path}: the live board went away ({exc})"
            ) from None

    def _parting_words(self) -> UserError | None:
        """What the server said before it closed the connection (a session it ended
        because the client was silent), if it said anything."""
        try:
            self._answer(self._receive(timeout=0.5))
        except ProtocolError:
            return None
        except UserError as exc:
            return exc
        return None

    def _receive(self, timeout: float | None = ANSWER_TIMEOUT_S) -> JSON:
        self.sock.settimeout(timeout)
        try:
            (length,) = LENGTH.unpack(self._exactly(LENGTH.size))
            if length > MAX_MESSAGE:
                raise self._malformed(f"it announces {length} bytes, more than any answer")
            data = self._exactly(length)
        except TimeoutError:
            raise ProtocolError(f"{self.path}: the live board did not answer") from None
        except OSError as exc:
            raise ProtocolError(f"{self.path}: the live board went away ({exc})") from None
        try:
            return decode(data)
        except ValueError as exc:
            raise self._malformed(f"not JSON: {exc}") from None

    def _exactly(self, size: int) -> bytes:
        data = b""
        while len(data) < size:
            chunk = self.sock.recv(size - len(data))
            if not chunk:
                raise ProtocolError(
                    f"{self.path}: the live board went away"
                    + (f" in the middle of an answer ({len(data)} of {size} bytes)" if data else "")
                )
            data += chunk
        return data

    def _malformed(self, what: str) -> ProtocolError:
        return ProtocolError(
            f"{self.path}: the live board's answer is malformed ({what}); is an asictl "
            "of another version serving it?"
        )

    def request(self, message: JSON) -> dict[str, JSON]:
        self._send(message)
        return self._answer(self._receive())

    def _answer(self, answer: JSON) -> dict[str, JSON]:
        if not isinstance(answer, dict):
            raise self._malformed(f"{_kind(answer)} instead of an object")
        ok = answer.get("ok")
        if ok is True:
            return answer
        error, code = answer.get("error"), answer.get("exit", 1)
        if ok is not False or not isinstance(error, str):
            raise self._malformed("neither a result nor an error")
        raise UserError(error, ExitCode(code) if code in (1, 2) else ExitCode.FAILED)

    def _field(self, answer: dict[str, JSON], name: str, kind: type) -> JSON:
        value = answer.get(name)
        if not isinstance(value, kind):
            what = "missing" if name not in answer else f"{_kind(value)}, not {kind.__name__}"
            raise self._malformed(f"'{name}' {what}")
        return value

    def hello(self) -> dict[str, JSON]:
        server = self._field(self.request({"op": "hello"}), "server", dict)
        assert isinstance(server, dict)
        self.server = server
        return self.server

    @contextmanager
    def session(self, who: str, waiting: Callable[[str], None] | None = None) -> Iterator[None]:
        """The board to this client alone; ``waiting`` hears who has it meanwhile (and
        how long the server lets a silent holder keep it), unless it is free again within
        ``QUIET_WAIT_S``."""
        self._send({"op": "begin", "who": who})
        answer = self._receive()
        if isinstance(answer, dict) and "waiting" in answer:
            if waiting is not None and not self._answered_within(QUIET_WAIT_S):
                limit = answer.get("idle_limit")
                waiting(str(answer["waiting"]) + (
                    f" (a session silent for {limit:g} s is ended)"
                    if isinstance(limit, int | float) and not isinstance(limit, bool) else ""
                ))
            answer = self._receive(timeout=None)
        self._answer(answer)
        try:
            yield
        finally:
            with contextlib.suppress(UserError):
                self.request({"op": "end"})

    def _answered_within(self, seconds: float) -> bool:
        readable, _, _ = select.select([self.sock], [], [], seconds)
        return bool(readable)

    def io(self, ops: list[JSON]) -> list[list[int]]:
        """The reads of ``ops``, each as many bytes as it asked for."""
        reads = self._field(self.request({"op": "io", "ops": ops}), "reads", list)
        counts = [op[2] for op in ops if op[0] == "r"]
        if len(reads) != len(counts) or not all(
            isinstance(read, list) and len(read) == count
            and all(isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= 0xFF
                    for v in read)
            for read, count in zip(reads, counts, strict=True)
        ):
            raise self._malformed(f"'reads' is not {len(counts)} lists of the bytes asked for")
        checked: list[list[int]] = reads
        return checked

    def action(self, name: str, **args: JSON) -> JSON:
        answer = self.request({"op": "action", "name": name, "args": args})
        if "result" not in answer:
            raise self._malformed("'result' missing")
        return answer["result"]

    def changes(self, since: int | None) -> tuple[list[Change], int]:
        """What clients changed on the board after the change numbered ``since`` (None:
        nothing yet, from now on), and the number to ask from next time."""
        answer = self.request({"op": "changes", "since": since})
        rows, after = self._field(answer, "changes", list), self._field(answer, "next", int)
        try:
            return [Change.from_json(row) for row in rows], after
        except (TypeError, ValueError):
            raise self._malformed("'changes' is not a list of changes") from None

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
    died is removed (only when the board's lock is free: a starting server keeps its).

    Only the user's own socket is used: something else at its place (a folder, a file)
    or a socket of another user, or a server running as another user, is refused.
    """
    path = socket_path(directory, base)
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise UserError(f"{path}: cannot reach the live board: {exc.strerror or exc}") from None
    if not stat.S_ISSOCK(info.st_mode):
        raise UserError(
            f"{path}: where board {port_name(base)}'s live socket belongs there is "
            f"{_file_kind(info.st_mode)}; asictl neither uses nor removes it: move it away",
            ExitCode.FAILED,
        )
    check_folder(directory)  # a loose folder lets others swap the socket after this
    if info.st_uid != os.geteuid():
        raise _foreign(path, "the socket belongs to", info.st_uid)
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
    uid = peer_uid(sock)
    if uid is not None and uid != os.geteuid():
        sock.close()
        raise _foreign(path, "the process serving it runs as", uid)
    client = LiveClient(sock, path)
    try:
        client.hello()
    except UserError:
        client.close()
        raise
    return client


def _foreign(path: Path, whose: str, uid: int) -> UnsafeStateFolder:
    return UnsafeStateFolder(
        f"{path}: {whose} another user (uid {uid}), not you: refusing to talk to it (your "
        "command would reach that user's board); remove it if you did not expect it"
    )


def _file_kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISLNK(mode):
        return "a symbolic link"
    if stat.S_ISREG(mode):
        return "a regular file"
    return "something other than a socket"


def _kind(value: JSON) -> str:
    names = {list: "a list", str: "a string", bool: "true/false", type(None): "null",
             int: "a number", float: "a number", dict: "an object"}
    return names.get(type(value), type(value).__name__)


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


#: The names of this machine's own address: a gateway listening on one is found under any.
_LOOPBACK = frozenset({"127.0.0.1", "localhost", "::1"})


def served_panel(directory: Path, host: str, tcp_port: int, unit: int) -> JSON | None:
    """The front panel of the gateway ``asictl gateway serve`` runs here for Modbus TCP
    ``host:tcp_port`` and ``unit``, None if none does (a real gateway, another machine's).

    What the display shows is partly the gateway's own knowledge (a message it latched
    after a key press, the slave it found wrong first), held in no register; a status read
    over Modbus takes the display from the panel itself where it can, so that it and
    ``gateway panel`` read one display."""
    for base in IO_BASES:
        try:
            client = open_live(directory, base)
        except UserError:
            continue
        if client is None:
            continue
        try:
            view = client.action("panel") if client.server.get("front_panel") else None
        except UserError:
            view = None
        finally:
            client.close()
        if isinstance(view, dict) and view.get("unit") == unit and _same_address(
            view.get("modbus_tcp"), host, tcp_port
        ):
            return view
    return None


def _same_address(listening: JSON, host: str, tcp_port: int) -> bool:
    if not isinstance(listening, list) or len(listening) != 2:
        return False
    their_host, their_port = listening
    same_host = their_host == host or {their_host, host} <= _LOOPBACK
    return same_host and their_port == tcp_port


def served_by(client: LiveClient) -> str:
    server = client.server
    return f"{server.get('command', 'a live board')} (pid {server.get('pid', '?')})"


@dataclass(frozen=True)
class LiveActions:
    """``EmulatedBoard`` for a live board, through its socket. It runs on by itself:
    after a change of the cable the command waits as long as a board loaded from its
    state file would run on (``SETTLE_MS``), so its report shows the effect too; after
    one the program sees in its next cycle (``NEXT_CYCLE``: inputs, forces) it goes on
    at once, as the action's answer is its report."""

    client: LiveClient

    @property
    def live(self) -> str:
        return served_by(self.client)

    def run(self, name: str, args: dict[str, JSON]) -> JSON:
        result = self.client.action(name, **args)
        if name not in VIEWS | NEXT_CYCLE:
            self.settle()
        return result

    def settle(self) -> None:
        time.sleep(SETTLE_MS / 1000)

    def wait_ms(self, ms: float) -> None:
        time.sleep(ms / 1000)
