"""The adapter's framing and requests against hostile input: nothing a client sends
crashes it or makes it wait for bytes that will not come."""

from __future__ import annotations

import io
import json
from pathlib import Path

from dap_client import DapClient
from hypothesis import given, settings
from hypothesis import strategies as st
from jsonrpc_framing import frame

from asictl.lsp.framing import MAX_BODY, Malformed, Reader, Writer


def request(seq: int, command: str, **arguments: object) -> bytes:
    return frame(json.dumps({"seq": seq, "type": "request", "command": command,
                             "arguments": arguments}).encode())


def read_all(data: bytes) -> list[object]:
    reader = Reader(io.BytesIO(data))
    found = []
    while (message := reader.read()) is not None:
        found.append(message)
    return found


def test_frames_in_a_row_with_other_headers():
    data = request(1, "a") + b"Content-Type: application/json\r\n" + request(2, "b")[0:] \
        + b"\r\n\r\n" + request(3, "c")
    assert [m["command"] for m in read_all(data)] == ["a", "b", "c"]  # type: ignore[index]


def test_bad_frames_are_reported_and_the_next_one_is_read():
    huge = b"Content-Length: %d\r\n\r\n" % (MAX_BODY * 1000) + b"x" * 5000  # never all sent
    data = (b"garbage before a header\r\n" + b"Content-Length: many\r\n\r\n{}"
            + frame(b"{not json") + frame(b"[1, 2]") + frame(b"\xff\xfe")
            + frame(b"[" * 100_000 + b"]" * 100_000) + huge + request(7, "after"))
    found = read_all(data)
    assert [type(m).__name__ for m in found] == ["Malformed"] * 6 + ["dict"]
    assert "not a number" in found[0].why  # type: ignore[union-attr]
    assert "larger than" in found[5].why  # type: ignore[union-attr]
    assert found[-1]["command"] == "after"  # type: ignore[index]


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=3000), st.lists(st.sampled_from(
    [b"Content-Length: ", b"\r\n", b"\r\n\r\n", b"12", b"{", b"}", b"\"", b"99999999999"]),
    max_size=30))
def test_any_bytes_end_in_messages_or_skips_never_an_exception(noise: bytes,
                                                                pieces: list[bytes]):
    data = noise + b"".join(pieces) + b"\r\n\r\n" + request(1, "last")
    found = read_all(data)
    assert all(isinstance(m, dict | Malformed) for m in found)


def test_a_writer_on_a_closed_stream_drops_messages():
    stream = io.BytesIO()
    writer = Writer(stream)
    stream.close()
    writer.write({"a": 1})
    assert writer.closed


def test_the_adapter_survives_hostile_messages_and_bad_requests(client: DapClient,
                                                               tmp_path: Path):
    client.send_raw(b"hello\r\n" + frame(b"{oops") + frame(b'"a string"')
                    + frame(b'{"type": "event", "event": "x"}')
                    + b"Content-Length: 999999999999\r\n\r\n")
    assert client.request("initialize", {"adapterID": "asictl"})["supportsSetVariable"]
    assert "does not know the request 'frobnicate'" in client.failing("frobnicate")
    assert "launch or attach first" in client.failing("setBreakpoints", {
        "source": {"path": "x.asi"}, "breakpoints": [{"line": 1}]})
    assert "launch or attach first" in client.failing("continue", {"threadId": 1})
    assert "needs a 'program'" in client.failing("launch", {})
    assert "must be a list of strings" in client.failing("launch", {
        "program": "x.asi", "set": 5})
    bad = tmp_path / "bad.asi"
    bad.write_text("[PROGRAM]\n    A   I 1.9\n")
    assert "the program has errors" in client.failing("launch", {"program": str(bad)})
    assert f"{bad}:2:" in client.console()  # the diagnostics, as asictl check gives them
    assert "skipped a malformed message" in client.console()
    missing = tmp_path / "missing.asi"
    assert "missing.asi" in client.failing("launch", {"program": str(missing)})
    assert "duration" in client.failing("launch", {"program": str(bad), "duration": "often"})
    client.request("disconnect")
    assert client.process.wait(timeout=10) == 0


def test_the_end_of_the_input_ends_the_adapter(client: DapClient, tmp_path: Path):
    program = tmp_path / "p.asi"
    program.write_text("[SETUP]\n1: iiii, 0\n[PROGRAM]\n    A   I 1.0\n    =   F 0.0\n")
    client.request("initialize", {})
    client.request("launch", {"program": str(program), "duration": "600s"})
    client.request("configurationDone")
    stdin = client.process.stdin
    assert stdin is not None
    stdin.close()  # the editor went away while the program runs
    assert client.process.wait(timeout=30) == 0
