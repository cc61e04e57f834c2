"""The REST API (asictl.web.app) against the OpenAPI description it serves, and hostile
requests: Starlette's TestClient on a board loaded in this process."""

from __future__ import annotations

import base64
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from starlette.testclient import TestClient
from web_program import PROGRAM, TOKEN, downloaded

from asictl.host.emulated.boards import emulated_board
from asictl.host.live import requests
from asictl.host.live.board import LiveBoard
from asictl.host.status import MasterStatus
from asictl.web.access import COOKIE, CSRF_HEADER, Access
from asictl.web.app import MAX_BODY, create_app
from asictl.web.board import WebBoard
from asictl.web.stream import Hub, Listener

BEARER = {"Authorization": f"Bearer {TOKEN}"}


@pytest.fixture
def board(tmp_path: Path) -> Iterator[WebBoard]:
    state = downloaded(tmp_path)
    with emulated_board(0x300, state, save=False) as pc2:
        yield WebBoard(LiveBoard(pc2), "300h")


def client(board: WebBoard, *, writable: bool = True, downloads: bool = False) -> TestClient:
    app = create_app(board, Hub(), Access(writable, TOKEN if writable else None),
                     downloads=downloads)
    return TestClient(app, base_url="http://127.0.0.1")


def conforms(document: dict[str, Any], path: str, method: str, code: int, body: Any) -> None:
    """``body`` is what the served description says ``method path`` answers with ``code``."""
    answer = document["paths"][path][method]["responses"][str(code)]
    schema = answer["content"]["application/json"]["schema"]
    jsonschema.validate(body, {**schema, "components": document["components"]})


def test_every_path_answers_as_its_description_says(board: WebBoard):
    web = client(board)
    document = web.get("/openapi.json").json()
    assert document["openapi"].startswith("3.")
    assert "bearer" in document["components"]["securitySchemes"]
    status = web.get("/api/status")
    conforms(document, "/api/status", "get", 200, status.json())
    assert status.json()["phase"] == "normal operation"
    assert status.json()["mode"] == "protected"
    assert status.json()["control_state"] == "running"
    assert status.json()["flags"][12] == 42

    by_name = web.get("/api/operands/Answer")
    conforms(document, "/api/operands/{name}", "get", 200, by_name.json())
    assert by_name.json() == {"operand": "FY 12", "symbol": "Answer", "value": 42}
    assert web.get("/api/operands/FY 12").json() == by_name.json()

    body = document["paths"]["/api/force"]["post"]["requestBody"]["content"]
    request = {"assignments": ["Start=1"]}
    jsonschema.validate(request, body["application/json"]["schema"])
    forced = web.post("/api/force", json=request, headers=BEARER)
    conforms(document, "/api/force", "post", 200, forced.json())
    assert forced.json()["forced"] == [{"operand": "I 1.0", "value": 1, "symbol": "Start"}]
    board.live.board.advance(50)
    assert web.get("/api/operands/Lamp").json()["value"] == 1
    assert web.get("/api/status").json()["forced"] == [
        {"operand": "I 1.0", "value": 1, "symbol": "Start"}]

    released = web.post("/api/unforce", json={"operands": ["Start"]}, headers=BEARER)
    conforms(document, "/api/unforce", "post", 200, released.json())
    assert released.json() == {"released": 1, "forced": []}

    written = web.post("/api/write", json={"assignments": ["FY 20=0x5A"]}, headers=BEARER)
    conforms(document, "/api/write", "post", 200, written.json())
    assert web.get("/api/operands/FY 20").json()["value"] == 0x5A

    stopped = web.post("/api/stop", headers=BEARER)
    conforms(document, "/api/stop", "post", 200, stopped.json())
    assert web.get("/api/status").json()["control_state"] != "running"
    started = web.post("/api/start", headers=BEARER)
    conforms(document, "/api/start", "post", 200, started.json())
    board.live.board.advance(50)
    assert web.get("/api/status").json()["control_state"] == "running"

    program = web.get("/api/program").json()
    texts = [line["text"] for line in program["lines"]]
    assert any("; the lamp follows it" in (text or "") for text in texts)
    lamp = next(line for line in program["lines"] if line["operand"] == "Q 1.0")
    assert lamp["symbol"] == "Lamp" and lamp["code"]
    lines = web.get("/api/program/lines").json()
    assert lines["state"] == "running"
    assert any(line["ran"] and line["accu1"] == 42 for line in lines["lines"])


def test_the_served_description_is_valid_openapi(board: WebBoard):
    from openapi_spec_validator import validate  # 0.5 s to import: only for this test

    for writable in (False, True):
        validate(client(board, writable=writable).get("/openapi.json").json())


def test_the_status_has_the_keys_of_status_json(board: WebBoard):
    served = client(board, writable=False).get("/api/status").json()
    assert set(served) == set(MasterStatus.__dataclass_fields__) | {"schema"}


def test_errors_are_json_with_the_command_lines_wording_and_exit_code(board: WebBoard):
    web = client(board)
    document = web.get("/openapi.json").json()
    unknown = web.get("/api/operands/Nobody")
    assert unknown.status_code == 400
    conforms(document, "/api/operands/{name}", "get", 400, unknown.json())
    assert unknown.json()["exit"] == 2 and "'Nobody' is not an operand" in unknown.json()["error"]
    timer = web.post("/api/force", json={"assignments": ["T 0=1"]}, headers=BEARER)
    assert timer.status_code == 400
    assert timer.json() == {"error": "'T 0' cannot be forced: a force holds inputs (I, IB), "
                            "outputs (Q, QB) and flags (F, FY)", "exit": 2}
    output = web.post("/api/write", json={"assignments": ["Q 1.0=1"]}, headers=BEARER)
    assert output.status_code in (200, 409)
    missing = web.get("/api/nothing")
    assert missing.status_code == 404 and missing.json()["exit"] == 2
    wrong_method = web.get("/api/force")
    assert wrong_method.status_code == 405 and "error" in wrong_method.json()


def test_a_read_only_server_refuses_every_write(board: WebBoard):
    web = client(board, writable=False)
    assert web.get("/api/session").json()["writable"] is False
    writes = (("/api/force", {"assignments": ["Start=1"]}), ("/api/unforce", {"all": True}),
              ("/api/write", {"assignments": ["F 1.0=1"]}), ("/api/start", {}),
              ("/api/stop", {}), ("/api/login", {"token": TOKEN}))
    for path, body in writes:
        refused = web.post(path, json=body, headers=BEARER)
        assert refused.status_code == 403, path
        assert "read-only" in refused.json()["error"]
    assert web.get("/api/status").json()["forced"] == []


def test_writes_need_the_token_or_a_login_with_its_csrf_token(board: WebBoard):
    web = client(board)
    force = {"assignments": ["F 3.0=1"]}
    assert web.post("/api/force", json=force).status_code == 401
    for header in (f"Bearer {TOKEN}x", f"Basic {TOKEN}", "Bearer", TOKEN, f"Bearer {TOKEN[:-1]}"):
        answer = web.post("/api/force", json=force, headers={"Authorization": header})
        assert answer.status_code == 401, header
        assert TOKEN not in answer.text
    assert web.post("/api/login", json={"token": "guess"}).status_code == 401
    assert COOKIE not in web.cookies

    login = web.post("/api/login", json={"token": TOKEN})
    assert login.status_code == 200
    csrf = login.json()["csrf"]
    assert "httponly" in login.headers["set-cookie"].lower()
    assert "samesite=strict" in login.headers["set-cookie"].lower()
    assert web.get("/api/session").json() == {
        "board": "300h", "writable": True, "logged_in": True, "csrf": csrf}
    without = web.post("/api/force", json=force)
    assert without.status_code == 403 and "CSRF" in without.json()["error"]
    forged = csrf[:-1] + ("1" if csrf.endswith("0") else "0")  # differs in its last character
    wrong = web.post("/api/force", json=force, headers={CSRF_HEADER: forged})
    assert wrong.status_code == 403
    done = web.post("/api/force", json=force, headers={CSRF_HEADER: csrf})
    assert done.status_code == 200

    other = client(board)  # another browser: the CSRF token alone is worth nothing
    assert other.post("/api/force", json=force, headers={CSRF_HEADER: csrf}).status_code == 401
    web.post("/api/logout")
    web.cookies.clear()
    assert web.post("/api/force", json=force, headers={CSRF_HEADER: csrf}).status_code == 401


def test_hostile_requests_get_json_refusals_and_change_nothing(board: WebBoard):
    web = client(board)
    for body in (b"{", b"[1, 2]", b'"text"', b"[" * 50_000, b"\xff\xfe"):
        answer = web.post("/api/force", content=body, headers=BEARER)
        assert answer.status_code == 400, body[:10]
        assert answer.json()["exit"] == 2
    for body in ({"assignments": "F 1.0=1"}, {"assignments": []}, {"assignments": [1]}, {}):
        assert web.post("/api/force", json=body, headers=BEARER).status_code == 400
    huge = web.post("/api/force", content=b" " * (MAX_BODY + 1), headers=BEARER)
    assert huge.status_code == 413
    assert web.get("/api/status").json()["forced"] == []
    assert web.get("/static/../board.py").status_code == 404
    assert web.get("/static/%2e%2e/board.py").status_code == 404
    rebinding = web.get("/api/status", headers={"Host": "attacker.example:80"})
    assert rebinding.status_code == 400
    assert "for this machine only, not for 'attacker.example:80'" in rebinding.json()["error"]
    assert web.get("/api/status", headers={"Host": "localhost:8080"}).status_code == 200
    script = web.get("/api/operands/<script>alert(1)</script>")
    assert script.status_code == 400
    assert script.headers["content-type"] == "application/json"
    page = web.get("/")
    policy = page.headers["content-security-policy"]
    assert "script-src 'self'" in policy and "unsafe-inline" not in policy
    assert page.headers["x-content-type-options"] == "nosniff"


def test_mode_store_and_a_slaves_address_and_parameter(board: WebBoard):
    web = client(board)
    document = web.get("/openapi.json").json()

    def post(path: str, body: dict[str, Any], template: str = "") -> dict[str, Any]:
        answer = web.post(path, json=body, headers=BEARER)
        assert answer.status_code == 200, answer.text
        conforms(document, template or path, "post", 200, answer.json())
        board.live.board.advance(50)
        return dict(answer.json())

    assert post("/api/mode", {"mode": "configuration"}) == {"mode": "configuration"}
    parameter = post("/api/slaves/1/parameter", {"value": 10}, "/api/slaves/{address}/parameter")
    assert parameter["slave"] == 1 and parameter["parameter"] == 10
    assert web.get("/api/status").json()["slaves"]["1"]["pi"] == 10
    post("/api/store", {"what": "parameters"})
    assert web.get("/api/status").json()["slaves"]["1"]["pp"] == 10
    post("/api/slaves/1/address", {"new": 5}, "/api/slaves/{address}/address")
    assert 5 in web.get("/api/status").json()["lds"]
    post("/api/store", {"what": "configuration"})
    assert web.get("/api/status").json()["lps"] == [5]
    assert post("/api/mode", {"mode": "protected"}) == {"mode": "protected"}

    taken = web.post("/api/slaves/5/address", json={"new": 40}, headers=BEARER)
    assert taken.status_code == 400 and taken.json()["exit"] == 2
    assert web.post("/api/mode", json={"mode": "fast"}, headers=BEARER).status_code == 400
    store = web.post("/api/store", json={"what": "everything"}, headers=BEARER)
    assert store.status_code == 400
    assert store.json()["error"] == "store 'everything': configuration or parameters"


def test_upload_answers_the_files_the_program_was_downloaded_from(
    board: WebBoard, tmp_path: Path,
):
    web = client(board, writable=False)
    document = web.get("/openapi.json").json()
    answer = web.get("/api/upload")
    conforms(document, "/api/upload", "get", 200, answer.json())
    files = answer.json()["files"]
    assert [f["name"] for f in files] == ["lamp.asi", "lamp.symbols.toml"]
    assert files[0]["text"] == PROGRAM
    for served in files:  # the exact bytes downloaded
        assert base64.b64decode(served["base64"]) == (tmp_path / served["name"]).read_bytes()


def test_a_program_is_downloaded_only_where_the_server_takes_programs(board: WebBoard):
    source = "[SETUP]\n1: iiii, 0\n\n[PROGRAM]\n L KB 7\n T FY 12\n BE\n"
    program = {"files": [{"name": "seven.asi", "text": source}], "start": "start"}
    refused = client(board).post("/api/download", json=program, headers=BEARER)
    assert refused.status_code == 403 and "--http-download" in refused.json()["error"]

    web = client(board, downloads=True)
    document = web.get("/openapi.json").json()
    assert web.post("/api/download", json=program).status_code == 401
    done = web.post("/api/download", json=program, headers=BEARER)
    assert done.status_code == 200, done.text
    conforms(document, "/api/download", "post", 200, done.json())
    board.live.board.advance(50)
    status = web.get("/api/status").json()
    assert status["program"]["identity"] == done.json()["identity"]
    assert status["flags"][12] == 7 and status["control_state"] == "running"
    assert [f["name"] for f in web.get("/api/upload").json()["files"]] == ["seven.asi"]

    broken = {"files": [{"name": "bad.asi", "text": "[PROGRAM]\n L KB 7\n T XY 12\n BE\n"}]}
    errors = web.post("/api/download", json=broken, headers=BEARER)
    assert errors.status_code == 409 and errors.json()["exit"] == 1
    assert errors.json()["error"].startswith("bad.asi:3:")
    assert "/tmp" not in errors.json()["error"]
    for name in ("../escape.asi", ".hidden.asi", "a/b.asi", ""):
        named = {"files": [{"name": name, "text": "[PROGRAM]\n BE\n"}]}
        answer = web.post("/api/download", json=named, headers=BEARER)
        assert answer.status_code == 400 and answer.json()["exit"] == 2, name
    assert web.get("/api/status").json()["program"]["identity"] == done.json()["identity"]


def test_while_a_command_holds_the_board_reads_answer_the_last_status_and_changes_wait(
    board: WebBoard,
):
    web = client(board)
    board.live.in_session = lambda: True
    assert web.get("/api/status").status_code == 409  # nothing read yet
    board.live.in_session = lambda: False
    before = web.get("/api/status").json()
    board.live.in_session = lambda: True
    assert web.get("/api/status").json() == before
    refused = web.post("/api/force", json={"assignments": ["Start=1"]}, headers=BEARER)
    assert refused.status_code == 409 and refused.json()["exit"] == 1
    assert "another command holds the board" in refused.json()["error"]
    board.live.in_session = lambda: False
    assert web.get("/api/status").json()["forced"] == []


def test_other_clients_changes_reach_the_events_with_their_names(board: WebBoard):
    """A change through the board's socket (here: its request, as the server runs it)
    and one of the page's own are events, each once; reads are none."""
    hub, listener = Hub(), Listener()
    hub.listeners.add(listener)
    hub.publish(board.status())
    assert listener.latest is not None
    listener.latest = None
    requests.action(board.live, {"name": "force", "args": {"changes": [["flags", 3, 1, 1]]}},
                    "asictl force (pid 7)")
    board.force(["F 4.0=1"])
    board.status()
    hub.changes(board.changes())
    assert [e["text"] for e in hub.events][-2:] == [
        "FORCE F 3.0=1 by asictl force (pid 7)", "FORCE F 4.0=1 by the web page"]
    assert listener.latest is not None  # heard at once
    assert board.changes() == []


class _Halted:
    """A debugger's hold at a breakpoint (debug.online), as the live board sees it."""

    def advance(self, ms: float) -> None:
        """The master stands still."""

    def refusal(self, action: str) -> str | None:
        return None

    def halted(self) -> str:
        return "halted at breakpoint line 6 by asictl dap (pid 7)"


def test_a_board_halted_by_a_debugger_is_read_and_named_and_not_changed(board: WebBoard):
    board.live.hold = _Halted()
    web = client(board)
    status = web.get("/api/status").json()
    assert status["held"] == "halted at breakpoint line 6 by asictl dap (pid 7)"
    refused = web.post("/api/force", json={"assignments": ["F 3.0=1"]}, headers=BEARER)
    assert refused.status_code == 409, refused.text
    assert ("the board is halted at breakpoint line 6 by asictl dap (pid 7): forcing would "
            "change it") in refused.json()["error"]
    board.live.hold = None
    assert board.status().forced == [] and board.changes() == []
