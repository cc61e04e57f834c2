"""A small Debug Adapter Protocol client for tests: ``python3 -m asictl dap`` in a
subprocess, spoken to over its stdin and stdout in Content-Length frames, as an editor
does. Events are kept in arrival order; ``wait_event`` takes the next one of a kind."""

from __future__ import annotations

import contextlib
import os
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from jsonrpc_framing import framed, read_messages

SRC = Path(__file__).resolve().parents[2] / "src"
TIMEOUT = 60.0


class DapError(AssertionError):
    """The adapter answered a request with success false."""


class DapClient:
    def __init__(self, cwd: Path, *args: str) -> None:
        env = dict(os.environ, PYTHONPATH=str(SRC))
        self.process = subprocess.Popen(
            [sys.executable, "-m", "asictl", "dap", *args], cwd=cwd, env=env,
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        )
        self.responses: queue.Queue[dict[str, Any]] = queue.Queue()
        self.events: queue.Queue[dict[str, Any]] = queue.Queue()
        #: every event, in order (output events included)
        self.seen: list[dict[str, Any]] = []
        self.seq = 0
        assert self.process.stdout is not None
        threading.Thread(target=read_messages, args=(self.process.stdout, self._deliver),
                         daemon=True).start()

    def _deliver(self, message: dict[str, Any]) -> None:
        if message["type"] == "event":
            self.seen.append(message)
            self.events.put(message)
        else:
            self.responses.put(message)

    def send_raw(self, data: bytes) -> None:
        stdin = self.process.stdin
        assert stdin is not None
        stdin.write(data)
        stdin.flush()

    def send(self, command: str, arguments: dict[str, Any] | None = None) -> int:
        self.seq += 1
        self.send_raw(framed({"seq": self.seq, "type": "request", "command": command,
                               "arguments": arguments or {}}))
        return self.seq

    def response(self, seq: int) -> dict[str, Any]:
        while True:
            reply = self.responses.get(timeout=TIMEOUT)
            if reply["request_seq"] == seq:
                return reply

    def request(self, command: str, arguments: dict[str, Any] | None = None) -> Any:
        reply = self.response(self.send(command, arguments))
        if not reply["success"]:
            raise DapError(f"{command}: {reply.get('message')}")
        return reply.get("body")

    def failing(self, command: str, arguments: dict[str, Any] | None = None) -> str:
        """The message of a request that must fail."""
        reply = self.response(self.send(command, arguments))
        assert not reply["success"], reply
        return str(reply["message"])

    def wait_event(self, name: str, timeout: float = TIMEOUT) -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        while True:
            event = self.events.get(timeout=max(0.01, deadline - time.monotonic()))
            if event["event"] == name:
                return event.get("body") or {}

    def console(self) -> str:
        return "".join(e["body"]["output"] for e in self.seen if e["event"] == "output")

    def stopped(self) -> dict[str, Any]:
        """The next stop, with where: ``{"reason", "file", "line", "frames"}``."""
        body = self.wait_event("stopped")
        frames = self.request("stackTrace", {"threadId": 1})["stackFrames"]
        top = frames[0]
        return {**body, "file": top.get("source", {}).get("name"), "line": top["line"],
                "frames": frames}

    def variables(self) -> dict[str, dict[str, str]]:
        """Scope name -> variable name -> value, at the current stop."""
        frame = self.request("stackTrace", {"threadId": 1})["stackFrames"][0]["id"]
        found = {}
        for scope in self.request("scopes", {"frameId": frame})["scopes"]:
            variables = self.request("variables",
                                     {"variablesReference": scope["variablesReference"]})
            found[scope["name"]] = {v["name"]: v["value"] for v in variables["variables"]}
        return found

    def close(self) -> None:
        if self.process.poll() is None:
            with contextlib.suppress(DapError, queue.Empty, OSError):
                self.request("disconnect", {})
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        for stream in (self.process.stdin, self.process.stdout, self.process.stderr):
            if stream is not None:
                stream.close()
