"""The language server against clients that misbehave or ask much: broken frames,
ill-typed parameters, lone surrogates, megabyte documents, hundreds of open files and
very long lines. Each case ends with a request that must still be answered.

(How long these take is measured by benchmarks/bench_lsp.py, not here.)"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from jsonrpc_framing import frame, framed
from lsp_client import LspClient

from asictl.lsp.server import DEBOUNCE_SECONDS

SMALL = "[SETUP]\n1: iiii, 0\n2: oooo, 0\n[PROGRAM]\n A I 1.0\n = Q 2.1\n"


def at(uri: str, line: int, character: int) -> dict[str, Any]:
    return {"textDocument": {"uri": uri}, "position": {"line": line, "character": character}}


def opened(client: LspClient, uri: str, text: str, version: int = 1) -> None:
    client.notify("textDocument/didOpen", {"textDocument": {
        "uri": uri, "languageId": "asi", "version": version, "text": text}})


def changed(client: LspClient, uri: str, text: str, version: int) -> None:
    client.notify("textDocument/didChange", {"textDocument": {"uri": uri, "version": version},
                                             "contentChanges": [{"text": text}]})


def hover_text(client: LspClient, uri: str, line: int, character: int) -> str | None:
    found = client.request("textDocument/hover", at(uri, line, character))
    return None if found is None else str(found["contents"]["value"])


def published(client: LspClient, uri: str, after: int = 0) -> list[list[dict[str, Any]]]:
    """The diagnostics of every publishDiagnostics for ``uri`` received so far."""
    return [m["params"]["diagnostics"] for m in client.notifications[after:]
            if m.get("method") == "textDocument/publishDiagnostics"
            and m["params"]["uri"] == uri]


@pytest.fixture
def client(tmp_path: Path) -> Iterator[LspClient]:
    client = LspClient(tmp_path)
    client.request("initialize", {"processId": None, "capabilities": {}})
    client.notify("initialized")
    yield client
    client.close()


@pytest.fixture
def small(client: LspClient, tmp_path: Path) -> str:
    """An open program with a hover on its line 4 (``A I 1.0``)."""
    uri = (tmp_path / "small.asi").as_uri()
    opened(client, uri, SMALL)
    assert client.diagnostics(uri) == []
    return uri


def still_served(client: LspClient, uri: str) -> None:
    text = hover_text(client, uri, 4, 3)
    assert text is not None and "slave 1, data bit D0" in text


# ------------------------------------------------------------------------- frames


def test_broken_frames_are_skipped_and_the_next_message_is_answered(
        client: LspClient, small: str):
    hover = {"jsonrpc": "2.0", "id": 900, "method": "textDocument/hover",
             "params": at(small, 4, 3)}
    body = json.dumps(hover).encode()
    client.send_raw(b"Content-Type: application/vscode-jsonrpc\r\n\r\n" + body)  # no length
    still_served(client, small)
    client.send_raw(frame(b'{"jsonrpc": "2.0", "id": 901, "method":'))  # not JSON
    still_served(client, small)
    client.send_raw(b"Content-Length: 12\r\n\r\n" + body)  # shorter than its body
    still_served(client, small)
    client.send_raw(b"Content-Length: twelve\r\n\r\n" + body)
    still_served(client, small)
    client.send_raw(frame(b"[1, 2, 3]") + frame(b"\xff\xfe{}") + frame(b"[" * 100_000))
    still_served(client, small)
    client.send_raw(b"Content-Length: 99999999999\r\n\r\n" + body)  # more than it reads
    still_served(client, small)
    # none of the broken ones was taken for a request, and each was logged
    assert not [m for m in client.notifications if m.get("id") in (900, 901)]
    logged = [m["params"]["message"] for m in client.notifications
              if m.get("method") == "window/logMessage"]
    assert sum("a message was skipped" in m for m in logged) >= 7, logged


# ------------------------------------------------------------------------ messages


def test_ill_typed_params_are_answered_invalid_params(client: LspClient, small: str):
    answer = client.answer({"method": "textDocument/hover", "params": {
        "textDocument": {"uri": small}, "position": "here"}})
    assert answer["error"]["code"] == -32602
    assert "position" in answer["error"]["message"]
    answer = client.answer({"method": "textDocument/hover", "params": at(small, -1, 0)})
    assert answer["error"]["code"] == -32602
    answer = client.answer({"method": "textDocument/definition", "params": {}})
    assert answer["error"]["code"] == -32602
    assert "textDocument" in answer["error"]["message"] or \
        "text_document" in answer["error"]["message"]
    # a notification with ill-typed params is logged, not answered; many of them write
    # nothing to standard error, which the client does not read (a full pipe would
    # stall the server)
    for _ in range(300):
        client.notify("textDocument/didOpen", {"textDocument": {"uri": small, "text": 5}})
    still_served(client, small)
    logged = [m["params"]["message"] for m in client.notifications
              if m.get("method") == "window/logMessage"]
    assert sum("textDocument/didOpen ignored: Invalid Params" in m for m in logged) == 300


def test_requests_that_are_not_json_rpc_are_answered_invalid_request(
        client: LspClient, small: str):
    client.send_raw(framed({"jsonrpc": "2.0", "id": [1], "method": "textDocument/hover",
                            "params": at(small, 4, 3)}))
    answer = client.response(None)
    assert answer["error"]["code"] == -32600
    answer = client.answer({"jsonrpc": "1.0", "method": "textDocument/hover",
                            "params": at(small, 4, 3)}, ident=77)
    assert answer["error"]["code"] == -32600
    answer = client.answer({"method": 42, "params": {}}, ident=78)
    assert answer["error"]["code"] == -32600
    answer = client.answer({"method": "asictl/nothing", "params": {}}, ident=79)
    assert answer["error"]["code"] == -32601
    still_served(client, small)


def test_lone_surrogates_are_replaced_and_positions_kept(client: LspClient, tmp_path: Path):
    uri = (tmp_path / "s.asi").as_uri()
    text = "[SETUP]\n1: iiii, 0\n[PROGRAM]\n A I 1.0 ; \ud800 \udfff\n \ud83d A I 1.9\n"
    opened(client, uri, text)  # json.dumps writes them as \ud800 escapes
    found = client.diagnostics(uri)
    assert found, "the stray character and I 1.9 are reported"
    assert all("Traceback" not in d["message"] for d in found)
    # the surrogate before A on line 4 took one UTF-16 unit, as U+FFFD does
    assert hover_text(client, uri, 3, 1) is not None
    assert "register := register and operand" in str(hover_text(client, uri, 3, 1))
    formatted = client.answer({"method": "textDocument/formatting", "params": {
        "textDocument": {"uri": uri}, "options": {"tabSize": 4, "insertSpaces": True}}})
    assert "error" not in formatted
    still = hover_text(client, uri, 3, 3)
    assert still is not None and "slave 1, data bit D0" in still


# ------------------------------------------------------------------------- sizes


def big_program(size: int, errors: int) -> str:
    """About ``size`` characters of statements with comments, ``errors`` of them spread
    evenly replaced by an operand out of range."""
    line = " A I 1.0            ; a comment that makes the line longer"
    count = size // (len(line) + 1)
    body = [line] * count
    for k in range(errors):
        body[k * count // errors] = " L KB 999"
    return "\n".join(["[SETUP]", "1: iiii, 0", "[PROGRAM]", *body, " BE", ""])


def test_a_megabyte_document_gets_its_diagnostics(client: LspClient, tmp_path: Path):
    uri = (tmp_path / "big.asi").as_uri()
    text = big_program(1 << 20, 2000)
    opened(client, uri, text)
    found = client.diagnostics(uri, until=bool)
    assert len([d for d in found if d["code"] == "E201"]) == 2000
    lines = text.split("\n")
    assert all(lines[d["range"]["start"]["line"]] == " L KB 999" for d in found)
    assert max(d["range"]["start"]["line"] for d in found) > 0.9 * len(lines)
    still = hover_text(client, uri, 4, 3)
    assert still is not None and "slave 1, data bit D0" in still


def test_a_hover_is_answered_while_a_big_document_is_checked_and_stale_diagnostics_are_dropped(
        client: LspClient, small: str, tmp_path: Path):
    uri = (tmp_path / "big.asi").as_uri()
    opened(client, uri, SMALL)
    assert client.diagnostics(uri) == []
    mark = len(client.notifications)
    changed(client, uri, big_program(600_000, 20_000), 2)  # seconds to check
    time.sleep(DEBOUNCE_SECONDS + 0.3)  # the check has begun
    answered = client.request("textDocument/hover", at(small, 4, 3))
    assert answered is not None
    # the hover was answered before any diagnostics of the big version came
    assert published(client, uri, mark) == []
    changed(client, uri, SMALL.replace("I 1.0", "I 1.9"), 3)
    found = client.diagnostics(uri, after=mark, until=bool)
    assert [d["code"] for d in found] == ["E201"]
    # version 2 was replaced while it was checked: its 20,000 errors were never sent
    assert all(len(d) <= 1 for d in published(client, uri, mark))


def test_three_hundred_open_documents_are_checked_once_each(client: LspClient,
                                                              tmp_path: Path):
    uris = [(tmp_path / f"p{n}.asi").as_uri() for n in range(300)]
    for n, uri in enumerate(uris):
        opened(client, uri, SMALL.replace("Q 2.1", f"Q 2.{n % 4}"))
    client.diagnostics(uris[-1])
    mark = len(client.notifications)
    changed(client, uris[0], SMALL.replace("I 1.0", "I 1.9"), 2)
    assert [d["code"] for d in client.diagnostics(uris[0], after=mark, until=bool)] == ["E201"]
    still_served(client, uris[150])
    # one change re-checks and publishes that document alone
    assert {m["params"]["uri"] for m in client.notifications[mark:]
            if m.get("method") == "textDocument/publishDiagnostics"} == {uris[0]}
    # and no document's diagnostics were sent more than once before
    for uri in uris[1:]:
        assert len(published(client, uri)) == 1, uri


def test_hover_and_completion_on_a_line_of_400000_characters(client: LspClient,
                                                             tmp_path: Path):
    uri = (tmp_path / "long.asi").as_uri()
    long = " A I 1.0 ; " + "ä" * 400_000
    opened(client, uri, f"[SETUP]\n1: iiii, 0\n[PROGRAM]\n{long}\n L KB 999\n")
    assert [d["code"] for d in client.diagnostics(uri, until=bool)] == ["E201"]
    text = hover_text(client, uri, 3, 5)
    assert text is not None and "slave 1, data bit D0" in text
    assert hover_text(client, uri, 3, len(long) - 1) is None  # in the comment
    assert hover_text(client, uri, 3, 10 * len(long)) is None  # beyond the line
    items = client.request("textDocument/completion", at(uri, 3, len(long)))["items"]
    assert items == []  # nothing to complete in a comment
    symbols = client.request("textDocument/documentSymbol", {"textDocument": {"uri": uri}})
    assert [s["name"] for s in symbols] == ["[SETUP]", "[PROGRAM]"]
