"""No client holds up the live board: a request does at most what the protocol needs,
the others are served between one client's requests, connections are capped (a flood or
a process out of descriptors is a line in the log, not megabytes), and a session whose
client went silent (stopped with SIGSTOP) is ended after its time-out.
"""

from __future__ import annotations

import json
import os
import resource
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from live_helpers import ROOT, cli, read_message, start_serve, stop, wait_for

from asictl.errors import UserError
from asictl.host.live.client import QUIET_WAIT_S, open_live
from asictl.host.live.protocol import (
    MAX_ACCESSES,
    MAX_COMMANDS,
    MAX_TRANSFER,
    encode,
    socket_path,
)
from asictl.host.live.server import WAITING_PER_SLOT, background_live
from asictl.platform.pc2 import COMMAND, PORT_DATA, PORT_INDEX, PORT_PAGE, Command


@pytest.fixture
def live(tmp_path: Path):
    with background_live(0x300, tmp_path, identity={"command": "test"}):
        yield tmp_path


def _ask(path: Path, message: object) -> dict:
    with socket.socket(socket.AF_UNIX) as sock:
        sock.connect(str(path))
        sock.sendall(encode(message))
        return json.loads(read_message(sock))


@pytest.mark.parametrize("ops, refusal", [
    ([["r", 0, 262_144]] * 100, f"at most {MAX_ACCESSES} at a time"),
    ([["r", 0, 1]] * (MAX_ACCESSES + 1), f"at most {MAX_ACCESSES} at a time"),
    ([["r", 0, MAX_TRANSFER + 1]], f"at most {MAX_TRANSFER} at a time"),
    ([["w", 0, [0] * 600], ["r", 0, 600]], f"at most {MAX_TRANSFER} at a time"),
])
def test_a_request_beyond_the_limits_is_refused_before_it_runs(live, ops, refusal):
    """The 2 KB request of 100 accesses of 262,144 reads took 14 s and 250 MB."""
    path = socket_path(live, 0x300)
    answer = _ask(path, {"op": "io", "ops": ops})
    assert answer["ok"] is False and answer["exit"] == 1 and refusal in answer["error"]
    assert _ask(path, {"op": "hello"})["ok"] is True


def test_the_largest_request_allowed_is_served(live):
    path = socket_path(live, 0x300)
    per = MAX_TRANSFER // MAX_ACCESSES
    answer = _ask(path, {"op": "io", "ops": [["r", 0, per]] * MAX_ACCESSES})
    assert answer["ok"] is True and [len(r) for r in answer["reads"]] == [per] * MAX_ACCESSES


def test_commands_in_one_request_are_counted(live):
    point = [["w", PORT_INDEX, [COMMAND & 0xFF]], ["w", PORT_PAGE, [COMMAND >> 8]]]
    status = ["w", PORT_DATA, [int(Command.GET_STATUS)]]
    allowed = [op for _ in range(MAX_COMMANDS) for op in [*point, status]]
    path = socket_path(live, 0x300)
    assert _ask(path, {"op": "io", "ops": [*allowed, ["r", PORT_DATA, 1]]})["ok"] is True
    answer = _ask(path, {"op": "io", "ops": [*allowed, *point, status]})
    assert answer["ok"] is False and f"more than {MAX_COMMANDS} commands" in answer["error"]


def test_other_clients_are_served_between_one_clients_requests(live):
    """A client that sends 300 requests at once does not keep another waiting for all of
    them: the other's hello is answered while most of the 300 are still to come."""
    path = socket_path(live, 0x300)
    greedy = socket.socket(socket.AF_UNIX)
    greedy.connect(str(path))
    request = encode({"op": "io", "ops": [["r", 0, 16]] * MAX_ACCESSES})
    sender = threading.Thread(target=greedy.sendall, args=(request * 300,))
    sender.start()
    assert wait_for(lambda: _pending(greedy) > 0)  # the server is at it
    other = open_live(live, 0x300)  # its hello is answered here
    assert other is not None
    answered = _pending(greedy)
    other.close()
    sender.join(30)
    assert answered < 300 * 0.9, f"{answered} of 300 answered before the other's hello"
    greedy.close()


def _pending(sock: socket.socket) -> int:
    """Answers waiting in ``sock``'s buffer (each ends with ']]}'), without reading them."""
    try:
        data = sock.recv(1 << 24, socket.MSG_PEEK | socket.MSG_DONTWAIT)
    except BlockingIOError:
        return 0
    return data.count(b"]]}")


# ------------------------------------------------------------------ many connections


def _connections(path: Path, count: int) -> list[socket.socket]:
    opened = []
    for _ in range(count):
        sock = socket.socket(socket.AF_UNIX)
        sock.settimeout(0.2)  # a full backlog makes connect() wait
        try:
            sock.connect(str(path))
        except OSError:
            sock.close()
            continue
        opened.append(sock)
    return opened


def _told(sock: socket.socket, timeout: float = 5) -> dict:
    """What the server said before closing ``sock`` (an empty dict: nothing)."""
    sock.settimeout(timeout)
    try:
        data = read_message(sock)
    except OSError:
        return {}
    return json.loads(data) if data else {}


def _stderr_after_stop(process: subprocess.Popen[str]) -> str:
    assert stop(process) == 0
    assert process.stderr is not None
    return process.stderr.read()


def test_connections_beyond_the_waiting_places_hear_busy_with_one_line_in_the_log(tmp_path):
    """A flood of 200 connections against 8 slots: 32 wait their turn, the rest are told
    at once that the board is busy (exit 1); the board serves again once they leave."""
    state = tmp_path / "state"
    process = start_serve(state, "--max-connections", "8")
    try:
        path = socket_path(state, 0x300)
        held = _connections(path, 8)
        assert wait_for(lambda: True, 0.3)
        flood = _connections(path, 200)
        told = _told(flood[-1])
        assert told["ok"] is False and told["exit"] == 1
        assert "the live board is busy" in told["error"] and "try again" in told["error"]
        for sock in flood + held:
            sock.close()
        assert wait_for(lambda: cli(state, "status").exit_code == 0)
    finally:
        log = _stderr_after_stop(process)
    assert log.count("8 clients connected (--max-connections) and 32 waiting: telling "
                     "further ones the board is busy") == 1, log
    assert "Traceback" not in log


def test_clients_beyond_the_limit_wait_their_turn_and_all_get_answers(tmp_path):
    """40 ``asictl status`` at once against 32 slots: 22 failed with "the live board went
    away (Connection reset by peer)"; here as many clients as 3 slots and their waiting
    places take, each holding the board for a session, all get their answers."""
    failures: list[BaseException] = []

    def command() -> None:
        try:
            client = open_live(tmp_path, 0x300)
            assert client is not None
            with client.session("a command"):
                client.io([["r", PORT_INDEX, 1]])
                time.sleep(0.05)
            client.close()
        except BaseException as exc:
            failures.append(exc)

    with background_live(0x300, tmp_path, identity={"command": "test"}, max_connections=3):
        threads = [threading.Thread(target=command) for _ in range(3 * (1 + WAITING_PER_SLOT))]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(60)
    assert failures == []


def test_a_client_that_waited_too_long_hears_busy(tmp_path):
    with background_live(
        0x300, tmp_path, identity={"command": "test"}, max_connections=1, admit_wait=0.5
    ):
        holder = open_live(tmp_path, 0x300)
        assert holder is not None
        with holder.session("a long command"):
            started = time.monotonic()
            with pytest.raises(UserError, match=r"the live board is busy: 1 clients are "
                               r"connected .* try again") as refused:
                open_live(tmp_path, 0x300)
            waited = time.monotonic() - started
        holder.close()
    assert refused.value.exit_code == 1 and 0.4 < waited < 5


def test_idle_connections_make_way_for_a_command(tmp_path):
    """32 idle connections took every slot for as long as they stayed open: every command
    failed with "the live board went away" while the board was up."""
    with background_live(0x300, tmp_path, identity={"command": "test"}, max_connections=4):
        idle = _connections(socket_path(tmp_path, 0x300), 4)
        time.sleep(0.2)
        client = open_live(tmp_path, 0x300)
        assert client is not None
        with client.session("a command"):
            assert len(client.io([["r", PORT_INDEX, 1]])[0]) == 1
        client.close()
        closed = [_told(sock, 0.5) for sock in idle]
        for sock in idle:
            sock.close()
    assert any("closed this connection: it sent nothing for" in told.get("error", "")
               for told in closed), closed


def test_a_connection_silent_for_the_idle_timeout_is_closed_and_told(tmp_path):
    with background_live(0x300, tmp_path, identity={"command": "test"}, idle_timeout=0.5):
        client = open_live(tmp_path, 0x300)
        assert client is not None
        time.sleep(1)
        with pytest.raises(UserError, match=r"closed this connection: it sent nothing for "
                           r"0\.5 s; run the command again"):
            client.hello()
        client.close()


def test_out_of_descriptors_the_server_logs_a_line_and_serves_on(tmp_path):
    """With few descriptors left (RLIMIT_NOFILE 48) 300 connections once wrote 96-160 MB
    of tracebacks in 20 s; now each condition is a line, and the board serves again once
    the connections are gone."""
    state = tmp_path / "state"

    def few_descriptors() -> None:
        resource.setrlimit(resource.RLIMIT_NOFILE, (48, 48))

    process = start_serve(state, "--max-connections", "1000", preexec_fn=few_descriptors)
    try:
        flood = _connections(socket_path(state, 0x300), 300)
        time.sleep(2.5)  # asyncio retries accept() every second
        for sock in flood:
            sock.close()
        assert wait_for(lambda: cli(state, "status").exit_code == 0, 10)
    finally:
        log = _stderr_after_stop(process)
    lines = log.splitlines()
    assert any("out of system resource" in line for line in lines), log
    assert len(lines) < 10 and len(log) < 4000, log
    assert "Traceback" not in log


# ------------------------------------------------------------------ a silent session


def test_a_silent_session_is_ended_and_the_waiting_client_told(tmp_path):
    with background_live(0x300, tmp_path, identity={"command": "test"}, session_timeout=1):
        holder, waiter = open_live(tmp_path, 0x300), open_live(tmp_path, 0x300)
        assert holder is not None and waiter is not None
        heard: list[str] = []
        with holder.session("a stopped command"):
            started = time.monotonic()
            with waiter.session("the next command", heard.append):
                waited = time.monotonic() - started
            with pytest.raises(UserError, match="ended this command's session: it sent "
                               "nothing for 1 s"):
                holder.hello()
    assert heard == ["a stopped command (a session silent for 1 s is ended)"]
    assert 0.9 < waited < 20


def _holding(client, who: str, seconds: float, gap: float = 0.0,
             rounds: int = 1) -> threading.Thread:
    """A thread where ``client`` holds the board ``rounds`` times for ``seconds`` each,
    ``gap`` apart (a monitor's refreshes); started once the first session is held."""
    holding = threading.Event()

    def hold() -> None:
        for _ in range(rounds):
            with client.session(who):
                holding.set()
                time.sleep(seconds)
            time.sleep(gap)

    thread = threading.Thread(target=hold)
    thread.start()
    holding.wait(5)
    return thread


def test_a_short_wait_for_the_board_is_not_announced(tmp_path):
    with background_live(0x300, tmp_path, identity={"command": "test"}):
        holder, waiter = open_live(tmp_path, 0x300), open_live(tmp_path, 0x300)
        assert holder is not None and waiter is not None
        heard: list[str] = []
        thread = _holding(holder, "asictl monitor (pid 1)", 0.2)
        started = time.monotonic()
        with waiter.session("asictl status (pid 2)", heard.append):
            waited = time.monotonic() - started
        thread.join()
    assert 0.05 < waited < QUIET_WAIT_S and heard == []


def test_commands_beside_a_monitor_say_nothing_of_waiting(tmp_path):
    """A monitor's refreshes hold the board briefly, over and over: the one-shot
    commands between them wait a little each, silently."""
    state = tmp_path / "state"
    process = start_serve(state)
    try:
        monitor = open_live(state, 0x300)
        assert monitor is not None
        thread = _holding(monitor, "asictl monitor (pid 1)", 0.1, gap=0.01, rounds=30)
        results = [cli(state, "status") for _ in range(4)]
        thread.join()
    finally:
        stop(process)
    assert all(result.exit_code == 0 for result in results)
    assert [result.stderr for result in results] == [""] * 4


CLIENT_HOLDING_A_SESSION = """
import sys, time
from pathlib import Path
from asictl.errors import UserError
from asictl.host.live.client import QUIET_WAIT_S, open_live
client = open_live(Path(sys.argv[1]), 0x300)
with client.session("asictl download (a stopped one)"):
    print("holding", flush=True)
    time.sleep(60)
"""


@pytest.mark.parametrize("wait", [[], ["--wait"]])
def test_a_client_stopped_with_sigstop_holds_the_board_no_longer_than_the_timeout(
    tmp_path, wait
):
    state = tmp_path / "state"
    process = start_serve(state, "--session-timeout", "1s")
    stopped = subprocess.Popen(
        [sys.executable, "-c", CLIENT_HOLDING_A_SESSION, str(state)], stdout=subprocess.PIPE,
        text=True, env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
    )
    try:
        assert stopped.stdout is not None and stopped.stdout.readline() == "holding\n"
        stopped.send_signal(signal.SIGSTOP)
        result = cli(state, "status", *wait)
    finally:
        stopped.kill()
        stopped.wait()
        log = _stderr_after_stop(process)
    assert result.exit_code == 0, result.output
    assert ("waiting for live board 300h, in use by asictl download (a stopped one) "
            "(a session silent for 1 s is ended)") in result.stderr
    assert "ended the session of asictl download (a stopped one): no request for 1 s" in log


# ------------------------------------------------------------------ hostile requests

_JSON = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**40), 2**40) | st.floats(allow_nan=False)
    | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=5) | st.dictionaries(st.text(max_size=8), inner,
                                                                 max_size=5),
    max_leaves=30,
)
_OPS = st.sampled_from(["hello", "begin", "end", "io", "action", "nope", None, 7])
_REQUESTS = st.fixed_dictionaries(
    {"op": _OPS},
    optional={"ops": st.lists(st.tuples(st.sampled_from(["r", "w", "x"]),
                                        st.integers(-2, 300), _JSON), max_size=4)
              | _JSON,
              "name": st.sampled_from(["inputs", "lines", "cable", "nope"]) | _JSON,
              "args": _JSON, "who": _JSON},
) | _JSON


@settings(max_examples=60, deadline=10_000, suppress_health_check=list(HealthCheck))
@given(request=_REQUESTS)
def test_a_hostile_request_gets_an_answer_or_a_closed_connection_never_a_dead_server(
    live, request
):
    path = socket_path(live, 0x300)
    with socket.socket(socket.AF_UNIX) as sock:
        sock.settimeout(10)
        sock.connect(str(path))
        sock.sendall(encode(request))
        answer = read_message(sock)
    if answer:
        told = json.loads(answer)
        assert told.get("ok") in (True, False), told
        if told["ok"] is False:
            assert isinstance(told["error"], str) and told["exit"] in (1, 2), told
    assert _ask(path, {"op": "hello"})["ok"] is True
