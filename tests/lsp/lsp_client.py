"""A minimal LSP client for tests: ``python3 -m asictl lsp`` in a subprocess, spoken to
over its stdin and stdout with JSON-RPC in Content-Length frames, as an editor does."""

from __future__ import annotations

import os
import queue
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from jsonrpc_framing import framed, read_messages

SRC = Path(__file__).resolve().parents[2] / "src"
TIMEOUT = 30.0


class LspClient:
    def __init__(self, cwd: Path, *args: str) -> None:
        env = dict(os.environ, PYTHONPATH=str(SRC))
        self.process = subprocess.Popen(
            [sys.executable, "-m", "asictl", "lsp", *args], cwd=cwd, env=env,
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        )
        self.messages: queue.Queue[dict[str, Any]] = queue.Queue()
        self.notifications: list[dict[str, Any]] = []
        self.next_id = 0
        assert self.process.stdout is not None
        threading.Thread(target=read_messages, args=(self.process.stdout, self.messages.put),
                         daemon=True).start()

    def send_raw(self, data: bytes) -> None:
        stdin = self.process.stdin
        assert stdin is not None
        stdin.write(data)
        stdin.flush()

    def send(self, content: dict[str, Any]) -> None:
        self.send_raw(framed({"jsonrpc": "2.0", **content}))

    def notify(self, method: str, params: dict[str, Any] | None = None) -> None:
        self.send({"method": method, "params": params or {}})

    def request(self, method: str, params: dict[str, Any] | None = None) -> Any:
        answer = self.answer({"method": method, "params": params or {}})
        assert "error" not in answer, answer["error"]
        return answer.get("result")

    def answer(self, content: dict[str, Any], ident: object = None) -> dict[str, Any]:
        """The whole response to a request (``content`` without its id: the next number,
        unless ``ident`` is given), the messages before it kept."""
        if ident is None:
            self.next_id += 1
            ident = self.next_id
        self.send({"id": ident, **content})
        return self.response(ident)

    def response(self, ident: object) -> dict[str, Any]:
        while True:
            message = self._next()
            if message.get("id") == ident and "method" not in message:
                return message
            self._keep(message)

    def _next(self, deadline: float | None = None) -> dict[str, Any]:
        wait = TIMEOUT if deadline is None else max(deadline - time.monotonic(), 0.01)
        try:
            return self.messages.get(timeout=wait)
        except queue.Empty:
            raise AssertionError("no message from the server in time") from None

    def _keep(self, message: dict[str, Any]) -> None:
        if "id" in message and "method" in message:  # a request to the client
            self.send({"id": message["id"], "result": None})
        else:
            self.notifications.append(message)

    def diagnostics(
        self, uri: str, after: int = 0,
        until: Callable[[list[dict[str, Any]]], bool] = lambda found: True,
    ) -> list[dict[str, Any]]:
        """The diagnostics of the first publishDiagnostics for ``uri`` from notification
        number ``after`` on that satisfies ``until``, waiting for it."""
        deadline = time.monotonic() + TIMEOUT
        while True:
            for message in self.notifications[after:]:
                if message.get("method") == "textDocument/publishDiagnostics" and \
                        message["params"]["uri"] == uri and until(
                        message["params"]["diagnostics"]):
                    return list(message["params"]["diagnostics"])
            after = len(self.notifications)  # each message is looked at once
            self._keep(self._next(deadline))

    def close(self) -> int:
        if self.process.poll() is None:
            self.process.kill()
        return self.process.wait(timeout=TIMEOUT)
