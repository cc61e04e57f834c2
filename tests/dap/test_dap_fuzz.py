"""Hostile DAP frames, generated, sent to one adapter process: requests with arguments of
the wrong type, unknown commands, missing or odd ``seq`` and ``command``, huge numbers,
NUL and lone surrogates in strings, deep nesting, bodies that are not JSON, bad
``Content-Length`` headers. A request is answered (a failure with a plain message, never
an internal error); a frame that cannot be a request is skipped with a note on the
console; and after each, a normal ``initialize`` is still answered. Sized for CI;
``-m slow`` runs many more examples."""

from __future__ import annotations

import itertools
import json
import queue
from collections.abc import Iterator
from typing import Any

import pytest
from dap_client import DapClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from jsonrpc_framing import frame

from asictl.lsp.framing import MAX_BODY

#: The commands a hostile request names: the adapter's own (but ``disconnect`` and
#: ``terminate``, which end it as asked) and some it does not know.
COMMANDS = ["initialize", "launch", "attach", "setBreakpoints", "setExceptionBreakpoints",
            "configurationDone", "threads", "stackTrace", "scopes", "variables",
            "setVariable", "evaluate", "pause", "source", "continue", "next", "stepIn",
            "stepOut", "stepCycle", "frobnicate", "", "\0", "\ud800", "x" * 5000]
KEYS = ["program", "cwd", "stateDir", "port", "duration", "set", "lib", "scenario",
        "noScenario", "stopOnEntry", "noDebug", "source", "breakpoints", "threadId",
        "frameId", "variablesReference", "name", "value", "expression", "sourceReference",
        "linesStartAt1", "path", "line"]

STRINGS = st.one_of(st.text(max_size=30), st.sampled_from([
    "\0", "a\0b", "\ud800", "x\udfff", "~", ".", "..", "/", "300h", "0x", "9" * 400,
    "I 4.0", "F 10.0", "Q 17.3 := 1", "600s", "-1s", "\x1b[2J", "%s%n", "../" * 50]))
SCALARS = st.one_of(st.none(), st.booleans(), st.integers(-2**70, 2**70),
                    st.sampled_from([2**63, -2**63 - 1, 10**400]),
                    st.floats(allow_nan=False, allow_infinity=False), STRINGS)
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.sampled_from(KEYS) | STRINGS, inner,
                                                 max_size=4)), max_leaves=12)
SEQS = st.one_of(st.integers(-2**70, 2**70), st.just(10**400), STRINGS, st.none())

MISSING = object()


@st.composite
def requests(draw: st.DrawFn) -> dict[str, Any]:
    """A request object: ``seq``, ``command`` and ``arguments`` each possibly odd or gone."""
    message: dict[str, Any] = {"type": draw(st.sampled_from(["request"] * 6 + [
        "event", "response", 1]))}
    for key, values in (("seq", SEQS), ("command", st.sampled_from(COMMANDS) | VALUES),
                        ("arguments", st.dictionaries(st.sampled_from(KEYS), VALUES,
                                                      max_size=5) | VALUES)):
        if draw(st.integers(0, 9)):
            message[key] = draw(values)
    return message


def deep(depth: int) -> bytes:
    return (b'{"seq": 5, "type": "request", "command": "launch", "arguments": {"program": '
            + b"[" * depth + b"]" * depth + b"}}")


#: Whole frames that are not requests: the adapter skips them, whatever they hold.
BAD_FRAMES = st.sampled_from([
    frame(b"{oops"), frame(b"\xff\xfe"), frame(b"[1, 2]"), frame(b"null"), frame(b""),
    frame(b'"\\ud800"'), frame(b"{" * 100_000), frame(deep(100_000)),
    b"Content-Length: many\r\n\r\n{}", b"Content-Length: -5\r\n\r\n{}",
    b"Content-Length: %d\r\n\r\n{}" % (MAX_BODY + 1),
    b"Content-Length: 99999999999999999999999\r\n\r\n",
    b"Content-Length: 3\r\n\r\n" + json.dumps({"seq": 1, "type": "request",
                                               "command": "threads"}).encode(),
    b"hello\r\n", b"\x00\x00\r\n", b"Content-Length:\r\n\r\n",
])


def encoded(message: dict[str, Any]) -> bytes:
    return frame(json.dumps(message).encode())


@pytest.fixture(scope="module")
def adapter(tmp_path_factory: pytest.TempPathFactory) -> Iterator[DapClient]:
    client = DapClient(tmp_path_factory.mktemp("dap-fuzz"))
    yield client
    client.close()


_MARKS = itertools.count(10**9)


def answers_then_initializes(client: DapClient, data: bytes) -> list[dict[str, Any]]:
    """Send ``data`` and then an ``initialize`` request; the replies before that one's."""
    mark = next(_MARKS)
    before = len(client.seen)
    client.send_raw(data + encoded({"seq": mark, "type": "request",
                                    "command": "initialize", "arguments": {}}))
    replies = []
    while True:
        try:
            reply = client.responses.get(timeout=20)
        except queue.Empty:
            raise AssertionError(f"no answer to initialize after {data[:300]!r}") from None
        if reply.get("request_seq") == mark:
            assert reply["success"] and reply["body"]["supportsSetVariable"]
            break
        replies.append(reply)
    for reply in replies:
        if not reply["success"]:
            assert reply["message"]
            assert "internal error" not in reply["message"], (data[:300], reply)
    notes = [e["body"]["output"] for e in client.seen[before:] if e["event"] == "output"]
    assert not any("internal error" in note for note in notes), notes
    return replies


def check_request(client: DapClient, message: dict[str, Any]) -> None:
    replies = answers_then_initializes(client, encoded(message))
    notes = "".join(e["body"]["output"] for e in client.seen if e["event"] == "output")
    if message["type"] == "request" and isinstance(message.get("command"), str):
        assert len(replies) == 1, (message, replies)
        assert replies[0]["command"] == message["command"]
        if message["command"] not in COMMANDS[:19]:
            assert "does not know the request" in replies[0]["message"]
    else:
        assert replies == []
        assert "skipped a message that is not a request" in notes


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(message=requests())
def test_a_hostile_request_is_answered_and_the_adapter_stays_up(adapter, message):
    check_request(adapter, message)


@settings(max_examples=20, deadline=None, suppress_health_check=list(HealthCheck))
@given(frames=st.lists(BAD_FRAMES, min_size=1, max_size=4))
def test_a_frame_that_is_no_request_is_skipped_and_the_adapter_stays_up(adapter, frames):
    assert answers_then_initializes(adapter, b"".join(frames)) == []
    assert "skipped a malformed message" in "".join(
        e["body"]["output"] for e in adapter.seen if e["event"] == "output")


@pytest.mark.slow
@settings(max_examples=1500, deadline=None, suppress_health_check=list(HealthCheck))
@given(message=requests())
def test_a_hostile_request_is_answered_and_the_adapter_stays_up_long_run(adapter, message):
    check_request(adapter, message)

