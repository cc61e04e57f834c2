"""Only the user's own live board is talked to, and only its owner talks to a live board.

A socket planted where the live socket belongs (by another user, who could write a
shared state folder or rename a socket in) once took the owner's download to the other
user's board, reported as success; it is refused before a request is sent, by the socket
file's owner and by the serving process's user (SO_PEERCRED). Something else at the
socket's place, and an answer that is not the protocol's, are plain errors.
"""

from __future__ import annotations

import json
import os
import struct
import subprocess
from pathlib import Path

import click
import pytest
from live_helpers import BLINK, cli, fake_server
from two_users import NOBODY, SYSTEM_PYTHON, as_nobody, as_root, start_as_nobody

from asictl.cli import main
from asictl.host.live.protocol import LENGTH, socket_path
from asictl.host.live.server import background_live

#: Listens as nobody at argv[1], notes each request's bytes in argv[2], answers as a
#: live board would: the board it serves is nobody's.
THEIR_BOARD = """
import json, socket, struct, sys
server = socket.socket(socket.AF_UNIX)
server.bind(sys.argv[1])
server.listen()
print("ready", flush=True)
answer = json.dumps({"ok": True, "server": {"command": "theirs"}, "reads": [[0]]}).encode()
while True:
    conn, _ = server.accept()
    data = conn.recv(65536)
    if data:
        with open(sys.argv[2], "ab") as log:
            log.write(data + b"\\n")
        conn.sendall(struct.pack(">I", len(answer)) + answer)
    conn.close()
"""


def _their_board(folder: Path) -> tuple[subprocess.Popen[str], Path, Path]:
    """nobody's board listening in ``folder``/theirs: the process, its socket, its log."""
    theirs = folder / "theirs"
    theirs.mkdir()
    os.chown(theirs, NOBODY, NOBODY)
    path, log = theirs / "pc2-300h.sock", theirs / "heard"
    process = start_as_nobody(SYSTEM_PYTHON, "-c", THEIR_BOARD, str(path), str(log))
    assert process.stdout is not None and process.stdout.readline() == "ready\n"
    return process, path, log


def _program_on(state: Path) -> str:
    return json.loads((state / "pc2-300h.json").read_text())["eeprom"]


@as_root
@pytest.mark.parametrize("disguise", ["none", "socket file made the owner's"])
def test_a_socket_another_user_planted_is_refused_never_a_download(open_folder, disguise):
    state = open_folder / "state"
    assert cli(state, "status").exit_code == 0
    before = _program_on(state)
    process, path, log = _their_board(open_folder)
    try:
        path.rename(socket_path(state, 0x300))  # planted: the inode, its owner, listening
        if disguise != "none":
            os.chown(socket_path(state, 0x300), 0, 0)
        result = cli(state, "download", str(BLINK))
    finally:
        process.kill()
        process.wait()
    assert result.exit_code == 2, result.output
    assert "another user (uid 65534), not you: refusing to talk to it" in result.stderr
    whose = "the socket belongs to" if disguise == "none" else "the process serving it runs as"
    assert whose in result.stderr
    assert "downloaded" not in result.output
    assert not log.exists(), "not one request reached the other user's board"
    assert _program_on(state) == before


@as_root
def test_a_shared_state_folder_with_their_socket_is_refused(open_folder):
    process, path, log = _their_board(open_folder)
    try:
        path.parent.chmod(0o777)
        result = cli(path.parent, "download", str(BLINK))
    finally:
        process.kill()
        process.wait()
    assert result.exit_code == 2 and "belongs to another user" in result.stderr
    assert not log.exists()


#: Connects as nobody to argv[1] and prints what the server answers to a hello.
HELLO = """
import json, socket, struct, sys
client = socket.socket(socket.AF_UNIX)
client.connect(sys.argv[1])
body = json.dumps({"op": "hello"}).encode()
try:
    client.sendall(struct.pack(">I", len(body)) + body)
except BrokenPipeError:
    pass  # the server may have answered and closed before the hello
head = client.recv(4)
print(client.recv(struct.unpack(">I", head)[0]).decode() if len(head) == 4 else "closed")
"""


@as_root
def test_the_server_serves_its_owner_only(open_folder):
    """Even where the socket's mode would let another user in (here opened on purpose),
    the server asks who connects and answers a stranger with a refusal only."""
    state = open_folder / "state"
    state.mkdir(mode=0o755)
    state.chmod(0o755)
    with background_live(0x300, state, identity={"command": "test"}) as path:
        path.chmod(0o666)
        stranger = as_nobody(SYSTEM_PYTHON, "-c", HELLO, str(path), timeout=30)
        own = cli(state, "status")
    assert stranger.returncode == 0, stranger.stderr
    answer = json.loads(stranger.stdout)
    assert answer == {"ok": False, "exit": 1,
                      "error": "this live board serves only the user who runs it"}
    assert own.exit_code == 0, own.output


# ------------------------------------------------------------------ not a socket there

#: Each command that reaches a board, with what it needs besides --state-dir.
BOARD_COMMANDS = {
    "bus inputs": ["4", "0b0001"], "bus match": [], "bus plug": ["4", "0,0"],
    "bus show": [], "bus unplug": ["4"], "diag": [], "download": [str(BLINK)],
    "emc": ["1", "--for", "1s"], "gateway panel": [], "gateway press": ["mode"],
    "gateway serve": ["--tcp", "127.0.0.1:0"], "mode": [], "monitor": [],
    "record": ["--duration", "1s", "-o", "run.scenario.toml"], "reset": [],
    "probe": ["-o", "p.json"], "serve": [], "setup": [str(BLINK)], "slave address": ["4", "5"],
    "slave command": ["4", "1"], "slave parameter": ["4", "1"], "start": [],
    "status": [], "stop": [], "store": ["configuration"], "upload": ["-o", "-"],
    "verify": [str(BLINK)], "write": ["F 1.0=1"],
    "hiflags": [], "force": ["F 1.0=1"], "unforce": ["--all"],
    "watch": ["F 1.0", "--duration", "1s"],
}


def _board_commands() -> list[str]:
    """Every command with a --state-dir, by walking the command tree."""
    context = click.Context(main)
    found = []

    def walk(command: click.Command, path: list[str]) -> None:
        if isinstance(command, click.Group):
            for name in command.list_commands(context):
                sub = command.get_command(context, name)
                assert sub is not None
                walk(sub, [*path, name])
        elif any(p.name == "state_dir" for p in command.params):
            found.append(" ".join(path))

    walk(main, [])
    return found


def test_the_table_names_every_command_that_reaches_a_board():
    assert sorted(_board_commands()) == sorted(BOARD_COMMANDS)


@pytest.mark.parametrize("command", sorted(BOARD_COMMANDS))
@pytest.mark.parametrize("thing", ["directory", "file"])
def test_something_else_where_the_socket_belongs_is_a_plain_error(tmp_path, command, thing):
    state = tmp_path / "state"
    state.mkdir(mode=0o700)
    where = socket_path(state, 0x300)
    where.mkdir() if thing == "directory" else where.write_text("not a socket\n")
    result = cli(state, *command.split(), *BOARD_COMMANDS[command])
    assert result.exit_code == 1, result.output
    kind = "a directory" if thing == "directory" else "a regular file"
    assert f"where board 300h's live socket belongs there is {kind}" in result.stderr
    assert where.exists(), "left as it was"


# ------------------------------------------------------------------ hostile answers


def _framed(body: bytes) -> bytes:
    return LENGTH.pack(len(body)) + body


def _json(value: object) -> bytes:
    return _framed(json.dumps(value).encode())


#: Six ways a live server's answer can be wrong, each to the first request (hello).
MALFORMED = {
    "truncated length prefix": b"\x00\x00",
    "huge length": struct.pack(">I", 0xFFFF_FFF0) + b"{",
    "not JSON": _framed(b"\xff{nope"),
    "wrong JSON type": _json([1, 2, 3]),
    "missing fields": _json({"ok": True}),
    "wrong value types": _json({"ok": True, "server": "x"}),
}


@pytest.mark.parametrize("kind", sorted(MALFORMED))
def test_a_malformed_answer_is_a_plain_error(tmp_path, kind):
    state = tmp_path / "state"
    with fake_server(state, lambda request: MALFORMED[kind]) as heard:
        result = cli(state, "status")
    assert heard, "the client did ask"
    assert result.exit_code in (1, 2), result.output
    assert "pc2-300h.sock: the live board" in result.stderr


#: Answers that pass the hello but not the request after it.
BAD_READS = {
    "reads missing": {"ok": True},
    "reads of the wrong type": {"ok": True, "reads": {"a": 1}},
    "too few reads": {"ok": True, "reads": []},
    "a byte out of range": {"ok": True, "reads": [[300]]},
    "a read of the wrong length": {"ok": True, "reads": [[1, 2, 3, 4, 5]]},
    "an error without text": {"ok": False, "exit": 7},
    "ok neither true nor false": {"ok": "yes"},
}


@pytest.mark.parametrize("kind", sorted(BAD_READS))
def test_a_malformed_register_answer_is_a_plain_error(tmp_path, kind):
    def answer(request: bytes) -> bytes:
        if json.loads(request)["op"] == "hello":
            return _json({"ok": True, "server": {"command": "fake"}})
        if json.loads(request)["op"] == "begin":
            return _json({"ok": True})
        return _json(BAD_READS[kind])

    state = tmp_path / "state"
    with fake_server(state, answer, keep=True):
        result = cli(state, "status")
    assert result.exit_code in (1, 2), result.output
    assert "live board's answer is malformed" in result.stderr


def test_the_fake_server_stands_for_a_live_board(tmp_path):
    """The fake's well-formed answers are taken: the failures above are the answers'."""
    state = tmp_path / "state"
    with fake_server(state, lambda request: _json({"ok": True, "server": {"command": "fake",
                                                                             "pid": 1}})):
        result = cli(state, "serve")
    assert result.exit_code == 1 and "already served live by fake (pid 1)" in result.stderr


#: What a hostile server would put on the user's terminal: a window title and a bell.
ESCAPE = "\x1b]0;owned\x07\x1b[2J"


def test_an_error_text_with_an_escape_sequence_is_printed_escaped(tmp_path):
    """An error text with ESC ... BEL from the live socket was printed raw by status."""

    def answer(request: bytes) -> bytes:
        if json.loads(request)["op"] == "hello":
            return _json({"ok": True, "server": {"command": "fake"}})
        return _json({"ok": False, "error": f"no{ESCAPE}pe", "exit": 1})

    state = tmp_path / "state"
    with fake_server(state, answer, keep=True):
        result = cli(state, "status")
    assert result.exit_code == 1, result.output
    assert "\x1b" not in result.stderr and "\x07" not in result.stderr
    assert "no\\x1b]0;owned\\x07\\x1b[2Jpe" in result.stderr


def test_a_servers_name_with_an_escape_sequence_is_printed_escaped(tmp_path):
    state = tmp_path / "state"
    server = {"command": f"fake{ESCAPE}", "pid": 1}
    with fake_server(state, lambda request: _json({"ok": True, "server": server})):
        result = cli(state, "serve")
    assert result.exit_code == 1 and "\x1b" not in result.stderr
    assert "already served live by fake\\x1b]0;owned\\x07" in result.stderr
