"""``attach``: the program of a live emulated board (``asictl serve``), as a target.

The debugging happens inside the serving process (``debug.online``); this side speaks
to it over its debug socket with the live board's own client (``host.live.LiveClient``)
and waits for a stop by asking for the state every ``POLL_S``. ``attach``'s arguments:
``port`` (default 300h) and ``stateDir`` name the board as for every other command;
``program`` (optional) is the source the board runs, for the editor's files and the
symbol table beside it.
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from asictl.dap.adapter import resolve
from asictl.dap.targets import Frame, Placed, Scope, Stop, Wanted
from asictl.dap.variables import scopes
from asictl.debug.debugger import DebugError
from asictl.debug.inventory import Inventory
from asictl.debug.online import debug_socket_path
from asictl.diagnostics import DiagnosticError, render_text
from asictl.errors import UserError
from asictl.host.connection import client_name
from asictl.host.emulated.boards import state_directory
from asictl.host.live.client import LiveClient
from asictl.host.transports.ports import parse_port, port_name
from asictl.lsp.framing import JSON
from asictl.observe.operands import parse_operand
from asictl.observe.symbols import SymbolTable, symbols_for
from asictl.runtime.line_map import SourceLine

#: How often a running program's state is asked for.
POLL_S = 0.02


class AttachedTarget:
    def __init__(self, client: LiveClient, described: dict[str, Any],
                 program: Path | None, symbols: SymbolTable) -> None:
        self.client = client
        self._lock = threading.Lock()
        self._interrupted = False
        self._cycle = 0
        self.sources: dict[str, str] = dict(described.get("sources") or {})
        folder = program.parent if program is not None else None
        self.files: dict[str, Path] = {}
        for name in described.get("files") or []:
            if folder is not None and (folder / name).is_file():
                self.files[str(name)] = (folder / name).resolve()
                self.sources.pop(str(name), None)
        names = described.get("inventory") or {}
        self.inventory = Inventory(
            tuple(names.get("io", ())), tuple(names.get("flags", ())),
            tuple(names.get("timers_counters", ())),
            tuple(name for name, _ in symbols.entries.values())
            or tuple(names.get("symbols", ())))  # the board's table, without one here

    def _request(self, op: str, **fields: JSON) -> dict[str, Any]:
        with self._lock:
            answer = self.client.request({"op": op, **fields})
        assert isinstance(answer, dict)
        return answer

    def set_breakpoints(self, file: str, wanted: list[Wanted]) -> list[Placed]:
        answer = self._request("breakpoints", file=file, wanted=[
            [w.line, w.condition.strip(), w.hit_condition.strip()] for w in wanted])
        return [Placed(number, line, message) for number, line, message in answer["placed"]]

    def resume(self, how: str) -> Stop:
        self._interrupted = False
        self._request("resume", how=how)
        while True:
            state = self._request("state")
            stop = state.get("stop")
            if stop is not None:
                self._cycle = int(state.get("cycle", 0))
                return self._stop(stop)
            time.sleep(POLL_S)

    def _stop(self, stop: dict[str, Any]) -> Stop:
        if stop["kind"] == "end":
            return Stop("end", str(stop["text"]))
        if stop["kind"] == "fault":
            return Stop("exception", "program stopped", str(stop["text"]))
        if stop["breakpoint"] is not None:
            return Stop("breakpoint", breakpoints=(int(stop["breakpoint"]),))
        return Stop("pause" if self._interrupted else "step")

    def interrupt(self) -> None:
        self._interrupted = True
        self._request("interrupt")

    def frames(self) -> list[Frame]:
        answer = self._request("frames")
        lines = [SourceLine(str(file), int(line)) for file, line in answer["frames"]]
        if not lines:
            return [Frame("program stopped", None)]
        return [Frame(f"FB {at.file}" if at.file.lower().endswith(".fb")
                      else f"{at.file} (cycle {self._cycle})", at) for at in lines]

    def scopes(self) -> list[Scope]:
        constant = int(self._request("frames")["constant"])
        return scopes(self.inventory, self._show, constant)

    def _show(self, names: list[str]) -> list[str]:
        return [str(v) for v in self._request("values", names=names)["values"]]

    def evaluate(self, text: str) -> str:
        verb, _, rest = text.partition(" ")
        if verb.lower() in ("p", "print"):
            names = [n.strip() for n in rest.split(",") if n.strip()]
            return "\n".join(f"{n} = {v}" for n, v in zip(names, self._show(names),
                                                          strict=True))
        [shown] = self._show([text])
        if shown.startswith("("):
            raise DebugError(shown.strip("()"))
        return shown

    def assign(self, name: str, value: str) -> str:
        try:
            number = int(value.strip(), 0)
        except ValueError:
            raise DebugError(f"'{value.strip()}' is not a number") from None
        self._request("set", name=name, value=number)
        return str(number)

    def close(self) -> None:
        with contextlib.suppress(UserError):  # the board went away: nothing holds it
            self._request("detach")
        self.client.close()


def _symbols(program: Path | None) -> SymbolTable:
    """The symbol table beside the program (its operands are checked again by the board,
    which knows the program's variables)."""
    if program is None:
        return SymbolTable()
    try:
        return symbols_for(program, lambda text: str(parse_operand(text)))
    except DiagnosticError as exc:
        raise UserError(render_text(exc.diagnostics, {}).rstrip("\n")) from None


def attach(args: dict[str, JSON], out: Callable[[str], None]) -> AttachedTarget:
    base = parse_port(str(args.get("port") or "300h"))
    state_dir = args.get("stateDir")
    directory = state_directory(state_dir if isinstance(state_dir, str) else None)
    path = debug_socket_path(directory, base)
    program = resolve(args, "program")
    symbols = _symbols(program)
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.connect(str(path))
    except OSError:
        sock.close()
        raise UserError(f"no live board serves port {port_name(base)} here ({path}): start "
                        f"one with 'asictl serve --port {port_name(base)}'") from None
    client = LiveClient(sock, path)
    try:
        described = client.request({"op": "attach", "who": client_name(), "symbols": [
            list(entry) for entry in symbols.entries.values()]})
    except UserError:
        client.close()
        raise
    out(f"attached to the live board {port_name(base)} (image {described['identity']}); "
        "the master stands still while the program is paused")
    if program is not None and program.name not in (described.get("files") or []):
        out(f"warning: the board runs no code from {program.name} (its files with code: "
            f"{', '.join(described.get('files') or []) or 'none'}): breakpoints there stay "
            "unverified; download the program first")
    return AttachedTarget(client, described, program, symbols)
