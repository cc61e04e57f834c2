"""The ASGI application: the page, the REST API and its OpenAPI description
(docs/web.md). A thin view over web/board.py, which does what the commands do.

Errors are JSON, ``{"error": TEXT, "exit": N}``, with the command line's wording and exit
code (2 bad usage, 1 refused); the HTTP status says the same to HTTP clients (400, 409,
401/403 for a write without its token, 404, 405, 413). Every answer carries a Content
Security Policy that allows no inline script and nothing from elsewhere, so even a text
the page failed to escape could not run.
"""

from __future__ import annotations

import json
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from importlib import resources
from typing import Any

from starlette.applications import Starlette
from starlette.datastructures import Headers
from starlette.exceptions import HTTPException
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import JSONResponse, Response, StreamingResponse
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from asictl.errors import ExitCode, UserError
from asictl.host.emulated.actions import parse_address, parse_number
from asictl.web.access import COOKIE, CSRF_HEADER, Access
from asictl.web.board import WebBoard
from asictl.web.openapi import openapi
from asictl.web.stream import Hub, Listener

#: The largest request body taken (a list of assignments is a few hundred bytes).
MAX_BODY = 64 * 1024
#: Seconds between the comments that keep an idle event stream open through proxies.
KEEPALIVE_S = 15.0
#: Watch list entries one event stream takes.
MAX_WATCH = 64
HEADERS = {
    "content-security-policy": "default-src 'none'; script-src 'self'; style-src 'self'; "
    "img-src 'self' data:; connect-src 'self'; form-action 'self'; base-uri 'none'; "
    "frame-ancestors 'none'",
    "x-content-type-options": "nosniff",
    "referrer-policy": "no-referrer",
    "cache-control": "no-store",
}
_STATUS = {ExitCode.USAGE: 400, ExitCode.FAILED: 409}
#: The names a loopback server answers to (the Host header, without its port).
LOOPBACK_NAMES = ("localhost", "127.0.0.1", "[::1]")


class Refused(UserError):
    """A request the server turns away before the board hears of it (HTTP ``status``)."""

    def __init__(self, message: str, status: int, exit_code: ExitCode = ExitCode.FAILED) -> None:
        super().__init__(message, exit_code)
        self.status = status


def error(message: str, exit_code: int, status: int) -> JSONResponse:
    return JSONResponse({"error": message, "exit": exit_code}, status)


class Secured:
    """The security headers on every answer (pure ASGI: streams are not buffered), and
    on a loopback server only requests addressed to this machine by name: a page
    elsewhere whose name an attacker points at 127.0.0.1 (DNS rebinding) is refused."""

    def __init__(self, app: ASGIApp, loopback: bool) -> None:
        self.app, self.loopback = app, loopback

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def secured(message: Message) -> None:
            if message["type"] == "http.response.start":
                names = {name.lower() for name, _ in message.get("headers", [])}
                message["headers"] = list(message.get("headers", [])) + [
                    (k.encode(), v.encode()) for k, v in HEADERS.items()
                    if k.encode() not in names
                ]
            await send(message)

        host = Headers(scope=scope).get("host", "")
        name = host.rpartition(":")[0] if host.rpartition(":")[2].isdigit() else host
        if self.loopback and name not in LOOPBACK_NAMES:
            refusal = error(f"this server answers requests for this machine only, not for "
                            f"'{host[:60]}'", int(ExitCode.USAGE), 400)
            await refusal(scope, receive, secured)
            return
        await self.app(scope, receive, secured)


def create_app(
    board: WebBoard, hub: Hub, access: Access, *, loopback: bool = True,
    refresh: Callable[[], None] | None = None, downloads: bool = False,
) -> Starlette:
    """The application for ``board``; ``loopback``: answer only requests addressed to
    this machine by name (a page elsewhere cannot reach it through DNS rebinding);
    ``refresh``: read the board into ``hub`` now (the event stream's first message);
    ``downloads``: take programs (``--http-download``)."""

    def read() -> None:
        if refresh is not None:
            refresh()
        else:
            hub.publish(board.status())

    async def page(request: Request) -> Response:
        html = resources.files("asictl.web").joinpath("static/index.html").read_text("utf-8")
        return Response(html, media_type="text/html; charset=utf-8")

    async def status(request: Request) -> Response:
        return JSONResponse(board.status().to_json())

    async def operand(request: Request) -> Response:
        return JSONResponse(board.operand(request.path_params["name"]))

    async def program(request: Request) -> Response:
        return JSONResponse(board.program())

    async def downloaded(request: Request) -> Response:
        authorize(request)
        if not downloads:
            raise Refused("this web server takes no programs: start it with --http-download",
                          403)
        body = await _body(request)
        files = body.get("files")
        if not isinstance(files, list) or not files or not all(
            isinstance(f, dict) and isinstance(f.get("name"), str)
            and isinstance(f.get("text"), str) for f in files
        ):
            raise Refused("'files' must be a list of {\"name\": ..., \"text\": ...}, the "
                          "main file first", 400, ExitCode.USAGE)
        answer = board.download([(f["name"], f["text"]) for f in files],
                                str(body.get("start", "keep")))
        read()
        return JSONResponse(answer)

    async def uploaded(request: Request) -> Response:
        return JSONResponse(board.upload())

    async def lines(request: Request) -> Response:
        return JSONResponse(board.lines())

    async def session(request: Request) -> Response:
        session = request.cookies.get(COOKIE)
        logged_in = access.session_ok(session)
        return JSONResponse({
            "board": board.name, "writable": access.writable, "logged_in": logged_in,
            "csrf": access.csrf(session) if logged_in and session else None,
        })

    async def login(request: Request) -> Response:
        body = await _body(request)
        if not access.writable:
            raise _read_only()
        given = body.get("token")
        if not isinstance(given, str) or not access.token_ok(given):
            raise Refused("wrong token", 401)
        session = access.new_session()
        answer = JSONResponse({"csrf": access.csrf(session)})
        answer.set_cookie(COOKIE, session, httponly=True, samesite="strict", path="/")
        return answer

    async def logout(request: Request) -> Response:
        access.end_session(request.cookies.get(COOKIE))
        answer = JSONResponse({"logged_in": False})
        answer.delete_cookie(COOKIE, path="/")
        return answer

    def authorize(request: Request) -> None:
        if not access.writable:
            raise _read_only()
        header = request.headers.get("authorization")
        if header is not None:
            if not access.bearer_ok(header):
                raise Refused("wrong token in the Authorization header (Bearer TOKEN)", 401)
            return
        session = request.cookies.get(COOKIE)
        if not access.session_ok(session):
            raise Refused("log in first (the page's Log in), or send "
                          "'Authorization: Bearer TOKEN'", 401)
        if not access.csrf_ok(session, request.headers.get(CSRF_HEADER)):
            raise Refused("missing or wrong CSRF token (reload the page)", 403)

    async def force(request: Request) -> Response:
        authorize(request)
        body = await _body(request)
        forced = board.force(_texts(body, "assignments"))
        read()
        return JSONResponse({"forced": forced})

    async def unforce(request: Request) -> Response:
        authorize(request)
        body = await _body(request)
        every = body.get("all") is True
        answer = board.unforce(None if every else _texts(body, "operands"))
        read()
        return JSONResponse(answer)

    async def write(request: Request) -> Response:
        authorize(request)
        body = await _body(request)
        assignments = _texts(body, "assignments")
        board.write(assignments)
        read()
        return JSONResponse({"written": assignments})

    def control(start: bool) -> Callable[[Request], Awaitable[Response]]:
        async def endpoint(request: Request) -> Response:
            authorize(request)
            await _body(request)
            summary = board.start(start=start)
            read()
            return JSONResponse({"control": summary})

        return endpoint

    async def mode(request: Request) -> Response:
        authorize(request)
        wanted = (await _body(request)).get("mode")
        if wanted not in ("protected", "configuration"):
            raise Refused("'mode' must be \"protected\" or \"configuration\"", 400,
                          ExitCode.USAGE)
        now = board.mode(configuration=wanted == "configuration")
        read()
        return JSONResponse({"mode": now})

    async def store(request: Request) -> Response:
        authorize(request)
        what = (await _body(request)).get("what")
        board.store(str(what))
        read()
        return JSONResponse({"stored": what})

    async def slave_address(request: Request) -> Response:
        authorize(request)
        old = parse_address(request.path_params["address"])
        new = parse_address(str((await _body(request)).get("new")))
        board.slave_address(old, new)
        read()
        return JSONResponse({"slave": old, "address": new})

    async def slave_parameter(request: Request) -> Response:
        authorize(request)
        where = parse_address(request.path_params["address"], zero=False)
        value = parse_number(str((await _body(request)).get("value")), "parameter", 15)
        answer = board.slave_parameter(where, value)
        read()
        return JSONResponse({"slave": where, "parameter": value, "answer": answer})

    async def events(request: Request) -> Response:
        watch = request.query_params.getlist("watch")[:MAX_WATCH]
        listener = Listener()
        read()
        if hub.latest is not None:
            listener.offer(hub.latest)
        hub.listeners.add(listener)
        last_event = 0

        async def stream() -> AsyncIterator[str]:
            nonlocal last_event
            try:
                while True:
                    reading = await listener.next(KEEPALIVE_S)
                    if reading is None:
                        yield ": keepalive\n\n"
                        continue
                    news = [e for e in hub.events if e["id"] > last_event]
                    last_event = hub.serial
                    rows = board.watch(reading.status, watch) if watch else []
                    named = board.watch(reading.status, list(reading.status.symbols))
                    yield (
                        f'event: status\ndata: {{"status":{reading.text},'
                        f'"watch":{json.dumps(rows)},"symbols":{json.dumps(named)},'
                        f'"events":{json.dumps(news)},'
                        f'"read_at":{reading.at},"sent_at":{time.time()}}}\n\n'
                    )
            finally:
                hub.listeners.discard(listener)

        return StreamingResponse(stream(), media_type="text/event-stream",
                                 headers={"x-accel-buffering": "no"})

    async def schema(request: Request) -> Response:
        return JSONResponse(openapi(access.writable))

    async def user_error(request: Request, exc: Exception) -> Response:
        assert isinstance(exc, UserError)
        status = exc.status if isinstance(exc, Refused) else _STATUS.get(exc.exit_code, 409)
        return error(str(exc), int(exc.exit_code), status)

    async def http_error(request: Request, exc: Exception) -> Response:
        assert isinstance(exc, HTTPException)
        return error(str(exc.detail), int(ExitCode.USAGE), exc.status_code)

    async def bug(request: Request, exc: Exception) -> Response:
        return error(f"internal error (a bug in asictl): {exc!r}", int(ExitCode.BUG), 500)

    routes = [
        Route("/", page),
        Route("/openapi.json", schema),
        Route("/api/status", status),
        Route("/api/operands/{name:path}", operand),
        Route("/api/program", program),
        Route("/api/program/lines", lines),
        Route("/api/upload", uploaded),
        Route("/api/download", downloaded, methods=["POST"]),
        Route("/api/events", events),
        Route("/api/session", session),
        Route("/api/login", login, methods=["POST"]),
        Route("/api/logout", logout, methods=["POST"]),
        Route("/api/force", force, methods=["POST"]),
        Route("/api/unforce", unforce, methods=["POST"]),
        Route("/api/write", write, methods=["POST"]),
        Route("/api/start", control(True), methods=["POST"]),
        Route("/api/stop", control(False), methods=["POST"]),
        Route("/api/mode", mode, methods=["POST"]),
        Route("/api/store", store, methods=["POST"]),
        Route("/api/slaves/{address}/address", slave_address, methods=["POST"]),
        Route("/api/slaves/{address}/parameter", slave_parameter, methods=["POST"]),
        Mount("/static", StaticFiles(packages=[("asictl.web", "static")]), name="static"),
    ]
    return Starlette(
        routes=routes,
        middleware=[Middleware(Secured, loopback=loopback)],
        exception_handlers={UserError: user_error, HTTPException: http_error, Exception: bug},
    )


def _read_only() -> Refused:
    return Refused("this web server is read-only: start it with --http-writable and a token "
                   "to change the board", 403)


async def _body(request: Request) -> dict[str, Any]:
    """The request's JSON object (an empty body is an empty object), at most MAX_BODY."""
    data = bytearray()
    async for chunk in request.stream():
        data += chunk
        if len(data) > MAX_BODY:
            raise Refused(f"the request body is larger than {MAX_BODY} bytes", 413,
                          ExitCode.USAGE)
    if not data.strip():
        return {}
    try:
        body = json.loads(data)
    except (ValueError, RecursionError):
        raise Refused("the request body is not JSON", 400, ExitCode.USAGE) from None
    if not isinstance(body, dict):
        raise Refused("the request body must be a JSON object", 400, ExitCode.USAGE)
    return body


def _texts(body: dict[str, Any], key: str) -> list[str]:
    items = body.get(key)
    if not isinstance(items, list) or not items or not all(isinstance(i, str) for i in items):
        raise Refused(f"'{key}' must be a list of texts, e.g. [\"F 10.0=1\"]", 400,
                      ExitCode.USAGE)
    return items
