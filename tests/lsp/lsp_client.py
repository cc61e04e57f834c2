"""A minimal LSP client for tests: ``python3 -m asictl lsp`` in a subprocess, spoken to
over its stdin and stdout with JSON-RPC in Content-Length frames, as an editor does."""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

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
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        stream = self.process.stdout
        assert stream is not None
        while True:
            headers: dict[str, str] = {}
            while True:
                line = stream.readline()
                if not line:
                    return
                if line in (b"\r\n", b"\n"):
                    break
                name, _, value = line.decode("ascii").partition(":")
                headers[name.strip().lower()] = value.strip()
            body = stream.read(int(headers["content-length"]))
            self.messages.put(json.loads(body))

    def send(self, message: dict[str, Any]) -> None:
        body = json.dumps({"jsonrpc": "2.0", **message}).encode("utf-8")
        stdin = self.process.stdin
        assert stdin is not None
        stdin.write(b"Content-Length: %d\r\n\r\n" % len(body) + body)
        stdin.flush()

    def notify(self, method: str, params: dict[str, Any] | None = None) -> None:
        self.send({"method": method, "params": params or {}})

    def request(self, method: str, params: dict[str, Any] | None = None) -> Any:
        self.next_id += 1
        ident = self.next_id
        self.send({"id": ident, "method": method, "params": params or {}})
        while True:
            message = self._next()
            if message.get("id") == ident and "method" not in message:
                assert "error" not in message, message["error"]
                return message.get("result")
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
            self._keep(self._next(deadline))

    def close(self) -> int:
        if self.process.poll() is None:
            self.process.kill()
        return self.process.wait(timeout=TIMEOUT)
