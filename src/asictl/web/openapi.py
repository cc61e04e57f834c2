"""The REST API's OpenAPI description, served at ``/openapi.json`` (docs/web.md).

The status object's keys are those of ``MasterStatus`` (``status --json``), taken from
the dataclass itself so the description cannot drift from what is served.
"""

from __future__ import annotations

from dataclasses import fields
from typing import Any

import asictl
from asictl.host.status import STATUS_SCHEMA, MasterStatus

ERROR = {
    "type": "object", "required": ["error", "exit"],
    "properties": {
        "error": {"type": "string", "description": "the message the command line prints"},
        "exit": {"type": "integer", "description": "the command line's exit code: 2 bad "
                 "usage, 1 refused"},
    },
}
TEXTS = {"type": "array", "minItems": 1, "items": {"type": "string"}}
FORCED = {
    "type": "array", "items": {
        "type": "object", "required": ["operand", "value", "symbol"],
        "properties": {"operand": {"type": "string"}, "value": {"type": "integer"},
                       "symbol": {"type": ["string", "null"]}},
    },
}
OPERAND = {
    "type": "object", "required": ["operand", "symbol", "value"],
    "properties": {"operand": {"type": "string", "example": "I 4.0"},
                   "symbol": {"type": ["string", "null"]}, "value": {"type": "integer"}},
}


def status_schema() -> dict[str, Any]:
    keys = ["schema", *(f.name for f in fields(MasterStatus))]
    return {
        "type": "object", "required": keys,
        "description": "the object 'asictl status --json' prints (docs/commissioning.md)",
        "properties": {"schema": {"type": "integer", "const": STATUS_SCHEMA}},
    }


def _answer(schema: dict[str, Any], what: str = "done") -> dict[str, Any]:
    return {"description": what, "content": {"application/json": {"schema": schema}}}


def _errors(*codes: str) -> dict[str, Any]:
    return {code: _answer({"$ref": "#/components/schemas/Error"}, "refused") for code in codes}


def _write(summary: str, body: dict[str, Any] | None, answer: dict[str, Any]) -> dict[str, Any]:
    operation: dict[str, Any] = {
        "summary": summary, "security": [{"bearer": []}],
        "responses": {"200": _answer(answer), **_errors("400", "401", "403", "409")},
    }
    if body is not None:
        operation["requestBody"] = {
            "required": True, "content": {"application/json": {"schema": body}},
        }
    return {"post": operation}


def _slave(path: dict[str, Any]) -> dict[str, Any]:
    path["post"]["parameters"] = [{"name": "address", "in": "path", "required": True,
                                   "schema": {"type": "integer", "minimum": 0,
                                              "maximum": 31}}]
    return path


def openapi(writable: bool) -> dict[str, Any]:
    """The description; ``writable`` says in it whether this server takes writes."""
    assignments = {"type": "object", "required": ["assignments"],
                   "properties": {"assignments": {**TEXTS, "example": ["Motor=1"]}}}
    access = "takes writes with its token" if writable else "is read-only"
    return {
        "openapi": "3.1.0",
        "info": {"title": "asictl live board", "version": asictl.__version__,
                 "description": f"The live board's status, operands and forces; this server "
                 f"{access}. Errors are JSON with the command line's wording and exit code."},
        "components": {
            "securitySchemes": {"bearer": {"type": "http", "scheme": "bearer",
                                           "description": "--http-token-file or "
                                           "$ASICTL_HTTP_TOKEN"}},
            "schemas": {"Error": ERROR, "Status": status_schema()},
        },
        "paths": {
            "/api/status": {"get": {
                "summary": "The master's status, as 'asictl status --json'",
                "responses": {"200": _answer({"$ref": "#/components/schemas/Status"}),
                              **_errors("409")},
            }},
            "/api/operands/{name}": {"get": {
                "summary": "An operand by address ('I 4.0') or by symbol ('Start')",
                "parameters": [{"name": "name", "in": "path", "required": True,
                                "schema": {"type": "string"}}],
                "responses": {"200": _answer(OPERAND), **_errors("400", "409")},
            }},
            "/api/program": {"get": {
                "summary": "The program's IL lines with their comments",
                "responses": {"200": _answer({"type": "object",
                                              "required": ["identity", "note", "lines"]})},
            }},
            "/api/program/lines": {"get": {
                "summary": "RLO and ACCU per IL line in the latest cycle (the monitor's v)",
                "responses": {"200": _answer({"type": "object",
                                              "required": ["state", "note", "lines"]}),
                              **_errors("409")},
            }},
            "/api/upload": {"get": {
                "summary": "The files 'asictl upload' would write, main file first",
                "responses": {"200": _answer({
                    "type": "object", "required": ["identity", "files"], "properties": {
                        "identity": {"type": "string"},
                        "files": {"type": "array", "items": {
                            "type": "object", "required": ["name", "text", "base64"],
                            "properties": {"name": {"type": "string"},
                                           "text": {"type": "string"},
                                           "base64": {"type": "string"}}}}}}),
                              **_errors("409")},
            }},
            "/api/events": {"get": {
                "summary": "Server-sent events: the status at every change, the watch "
                "list's values, every symbol's value and the event log",
                "parameters": [{"name": "watch", "in": "query", "required": False,
                                "schema": {"type": "array", "items": {"type": "string"}},
                                "explode": True}],
                "responses": {"200": {"description": "a stream",
                                      "content": {"text/event-stream": {}}}},
            }},
            "/api/force": _write("Force operands (asictl force)", assignments,
                                 {"type": "object", "required": ["forced"],
                                  "properties": {"forced": FORCED}}),
            "/api/unforce": _write(
                "Release forces (asictl unforce): operands, or all",
                {"type": "object", "properties": {"operands": TEXTS,
                                                  "all": {"type": "boolean"}}},
                {"type": "object", "required": ["released", "forced"],
                 "properties": {"released": {"type": "integer"}, "forced": FORCED}}),
            "/api/write": _write("Write flags and outputs (asictl write)", assignments,
                                 {"type": "object", "required": ["written"]}),
            "/api/start": _write("Set the start flag (asictl start)", None,
                                 {"type": "object", "required": ["control"]}),
            "/api/stop": _write("Clear the start flag (asictl stop)", None,
                                {"type": "object", "required": ["control"]}),
            "/api/download": _write(
                "Download a program (asictl download), only with --http-download",
                {"type": "object", "required": ["files"], "properties": {
                    "files": {"type": "array", "minItems": 1, "items": {
                        "type": "object", "required": ["name", "text"],
                        "properties": {"name": {"type": "string"},
                                       "text": {"type": "string"}}}},
                    "start": {"enum": ["start", "stop", "keep"]}}},
                {"type": "object", "required": ["identity", "size", "control"]}),
            "/api/mode": _write(
                "Switch the mode (asictl mode)",
                {"type": "object", "required": ["mode"], "properties": {
                    "mode": {"enum": ["protected", "configuration"]}}},
                {"type": "object", "required": ["mode"]}),
            "/api/store": _write(
                "Store the actual configuration or parameters (asictl store)",
                {"type": "object", "required": ["what"], "properties": {
                    "what": {"enum": ["configuration", "parameters"]}}},
                {"type": "object", "required": ["stored"]}),
            "/api/slaves/{address}/address": _slave(_write(
                "Give a slave another address (asictl slave address)",
                {"type": "object", "required": ["new"],
                 "properties": {"new": {"type": "integer", "minimum": 0, "maximum": 31}}},
                {"type": "object", "required": ["slave", "address"]})),
            "/api/slaves/{address}/parameter": _slave(_write(
                "Write a slave's parameter (asictl slave parameter)",
                {"type": "object", "required": ["value"],
                 "properties": {"value": {"type": "integer", "minimum": 0, "maximum": 15}}},
                {"type": "object", "required": ["slave", "parameter", "answer"]})),
        },
    }
