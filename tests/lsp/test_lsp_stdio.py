"""The language server over stdio, driven as an editor drives it: initialize, open,
change, hover, definition, references, completion, formatting, symbols, shutdown, exit."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from lsp_client import LspClient

from asictl.il.format import format_text

MAIN = """\
[SETUP]
1: iiii, 0
2: oooo, 0

[DECL]
Latch FB latch.fb

[PROGRAM]
        A   I 1.9           ; bit 9 does not exist
        JC  = end
        L   KT 500
        S   T 3
***
 A I 1.0
 =   Q 2.0
 JU FB Latch
end:    BE
"""
BLOCK = "[PROGRAM]\n        A   F 20.0\n        =   F 20.2\n"


def doc(uri: str) -> dict[str, Any]:
    return {"textDocument": {"uri": uri}}


def at(uri: str, line: int, character: int) -> dict[str, Any]:
    return {**doc(uri), "position": {"line": line, "character": character}}


@pytest.fixture
def session(tmp_path: Path) -> Iterator[tuple[LspClient, str, Path]]:
    (tmp_path / "main.asi").write_text(MAIN)
    (tmp_path / "latch.fb").write_text(BLOCK)
    client = LspClient(tmp_path)
    result = client.request("initialize", {
        "processId": None, "rootUri": tmp_path.as_uri(), "capabilities": {}})
    capabilities = result["capabilities"]
    for provider in ("hoverProvider", "definitionProvider", "referencesProvider",
                     "completionProvider", "documentSymbolProvider",
                     "documentFormattingProvider", "foldingRangeProvider"):
        assert capabilities.get(provider), provider
    client.notify("initialized")
    uri = (tmp_path / "main.asi").as_uri()
    client.notify("textDocument/didOpen", {"textDocument": {
        "uri": uri, "languageId": "asi", "version": 1, "text": MAIN}})
    yield client, uri, tmp_path
    client.close()


def test_a_whole_session(session: tuple[LspClient, str, Path]):
    client, uri, tmp_path = session

    # diagnostics on open: A I 1.9 is an error on its line (0-based 8), with its code
    diagnostics = client.diagnostics(uri)
    assert [(d["range"]["start"]["line"], d["severity"], d["code"]) for d in diagnostics] == [
        (8, 1, "E201")]
    assert diagnostics[0]["range"] == {"start": {"line": 8, "character": 12},
                                       "end": {"line": 8, "character": 17}}

    # hover on an operand: its place and its slave's [SETUP] line
    text = client.request("textDocument/hover", at(uri, 13, 4))["contents"]["value"]
    assert "I 1.0" in text and "slave 1, data bit D0" in text and "`1: iiii, 0`" in text
    # on an instruction: its meaning
    text = client.request("textDocument/hover", at(uri, 14, 1))["contents"]["value"]
    assert "operand := register" in text
    # on a timer: the KT it is started with
    text = client.request("textDocument/hover", at(uri, 11, 13))["contents"]["value"]
    assert "started with `KT 500` (line 12)" in text

    # definition of `end` in `JC = end`: the label's line
    found = client.request("textDocument/definition", at(uri, 9, 15))
    assert found == [{"uri": uri, "range": {"start": {"line": 16, "character": 0},
                                            "end": {"line": 16, "character": 3}}}]
    # of a block: into its file; of an operand: its slave's [SETUP] line
    found = client.request("textDocument/definition", at(uri, 15, 8))
    assert [f["uri"] for f in found] == [(tmp_path / "latch.fb").as_uri()]
    found = client.request("textDocument/definition", at(uri, 14, 6))
    assert [f["range"]["start"]["line"] for f in found] == [2]

    # references of slave 2 from its [SETUP] line: the line itself and Q 2.0
    found = client.request("textDocument/references", {
        **at(uri, 2, 0), "context": {"includeDeclaration": True}})
    assert [f["range"]["start"]["line"] for f in found] == [2, 14]

    # completion at the start of an instruction offers the operators
    items = client.request("textDocument/completion", at(uri, 13, 1))["items"]
    labels = [i["label"] for i in items]
    assert {"A", "AN", "O", "="} <= set(labels)
    # after A I: the input bits of the slaves in [SETUP]
    items = client.request("textDocument/completion", at(uri, 13, 5))["items"]
    assert "1.0" in [i["label"] for i in items] and "2.0" not in [i["label"] for i in items]

    # outline: sections with the segments and labels of [PROGRAM]
    symbols = client.request("textDocument/documentSymbol", doc(uri))
    assert [s["name"] for s in symbols] == ["[SETUP]", "[DECL]", "[PROGRAM]"]
    segments = symbols[2]["children"]
    assert [s["name"] for s in segments] == ["segment 1", "segment 2"]
    assert [c["name"] for c in segments[1]["children"]] == ["end"]
    folds = client.request("textDocument/foldingRange", doc(uri))
    assert [(f["startLine"], f["endLine"]) for f in folds] == [(0, 2), (4, 5), (7, 16)]

    # formatting: edits that give the formatter's text
    edits = client.request("textDocument/formatting", {
        **doc(uri), "options": {"tabSize": 4, "insertSpaces": True}})
    assert apply(MAIN, edits) == format_text(MAIN)

    # a change: debounced diagnostics of the new text (which also reads the timer it
    # starts, or the analyses would warn W712)
    fixed = MAIN.replace("I 1.9", "I 1.3").replace(" A I 1.0", " A T 3")
    mark = len(client.notifications)
    client.notify("textDocument/didChange", {
        "textDocument": {"uri": uri, "version": 2},
        "contentChanges": [{"text": fixed}]})
    assert client.diagnostics(uri, after=mark) == []

    assert client.request("shutdown") is None
    client.notify("exit")
    assert client.process.wait(timeout=30) == 0


def apply(text: str, edits: list[dict[str, Any]]) -> str:
    lines = text.split("\n")
    for edit in edits:
        start, end = edit["range"]["start"], edit["range"]["end"]
        assert start["line"] == end["line"] and start["character"] == 0
        assert end["character"] == len(lines[start["line"]])
        lines[start["line"]] = edit["newText"]
    return "\n".join(lines)


def test_an_unsaved_block_buffer_is_read_instead_of_the_file(
        session: tuple[LspClient, str, Path]):
    client, uri, tmp_path = session
    client.diagnostics(uri)
    block = (tmp_path / "latch.fb").as_uri()
    mark = len(client.notifications)
    client.notify("textDocument/didOpen", {"textDocument": {
        "uri": block, "languageId": "asi", "version": 1,
        "text": "[PROGRAM]\n    A F 20.0\n    = Q 40.0\n"}})
    found = client.diagnostics(block, after=mark, until=bool)
    assert [(d["code"], d["range"]["start"]["line"]) for d in found] == [("E201", 2)]
    # the block is checked as part of the program that calls it: the main file's
    # diagnostics are published with it
    assert [d["code"] for d in client.diagnostics(uri, after=mark)] == ["E201"]
    # closing the buffer: the file on disk counts again
    mark = len(client.notifications)
    client.notify("textDocument/didClose", {"textDocument": {"uri": block}})
    assert client.diagnostics(block, after=mark) == []


def test_related_locations_and_utf16_columns(tmp_path: Path):
    text = "[SETUP]\n16: 8h, 0 ; Zähler 𝄞\n16: 0h, 0\n[PROGRAM]\n A I 16.0 ; 𝄞\n"
    path = tmp_path / "dup.asi"
    path.write_text(text)
    client = LspClient(tmp_path)
    try:
        client.request("initialize", {"processId": None, "capabilities": {}})
        client.notify("initialized")
        client.notify("textDocument/didOpen", {"textDocument": {
            "uri": path.as_uri(), "languageId": "asi", "version": 1, "text": text}})
        (duplicate,) = client.diagnostics(path.as_uri())
        assert duplicate["code"] == "E210"
        (related,) = duplicate["relatedInformation"]
        assert related["message"] == "first set up here"
        assert related["location"]["range"]["start"]["line"] == 1
        # a formatting edit ends after the UTF-16 surrogate pair of the comment
        edits = client.request("textDocument/formatting", {
            "textDocument": {"uri": path.as_uri()},
            "options": {"tabSize": 4, "insertSpaces": True}})
        ends = {e["range"]["start"]["line"]: e["range"]["end"]["character"] for e in edits}
        assert ends[4] == len(" A I 16.0 ; ") + 2
    finally:
        client.close()


def test_formatting_refuses_a_file_with_syntax_errors(tmp_path: Path):
    text = "[PROGRAM]\n  A\n"
    path = tmp_path / "bad.asi"
    client = LspClient(tmp_path)
    try:
        client.request("initialize", {"processId": None, "capabilities": {}})
        client.notify("textDocument/didOpen", {"textDocument": {
            "uri": path.as_uri(), "languageId": "asi", "version": 1, "text": text}})
        assert [d["code"] for d in client.diagnostics(path.as_uri())] == ["E102"]
        edits = client.request("textDocument/formatting", {
            "textDocument": {"uri": path.as_uri()},
            "options": {"tabSize": 4, "insertSpaces": True}})
        assert edits is None
        shown = [m for m in client.notifications if m.get("method") == "window/showMessage"]
        assert "not formatted: 1 syntax error" in shown[-1]["params"]["message"]
    finally:
        client.close()
