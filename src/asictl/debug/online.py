"""Debugging the program of a live emulated board, inside ``asictl serve``.

A debugger (``asictl dap``'s ``attach``) connects to a socket beside the live board's
(``pc2-300h.debug.sock``, owner-only as well) and *holds* the board (``host.live.Hold``):
master time passes through it, in a worker thread that runs the board, so that the
program can pause inside a trap at an IL line as it does in ``debug.debugger``. Only one
of the two threads runs at a time: the server's loop waits while the worker runs a
slice of master time, and the worker waits while it is paused.

While the program is paused the whole master stands still, as a PLC halted at a
breakpoint does: master time, the AS-i cycle and the timers. Other clients still read
the communication memory and get answers to the commands that only read (51, 53, 56:
``asictl status``, the monitor, an upload), from the halted state, which the ``view``
action names (``host.live.board``); a command or action that would change the board is
refused with the debugger's name, and the monitor's program view (the ``lines`` action)
is turned away while a debugger holds the board, since both would watch the same lines. When the
debugger detaches, or its connection drops, the program runs on from where it was, and
master time follows the wall clock again from there.

The requests, one at a time, in the live board's framing (a 4-byte length and JSON):
``attach`` (``who``: the client, ``asictl dap (pid 7)``, which other clients of a
halted board are told; ``symbols``), ``breakpoints``, ``resume`` (``how``),
``interrupt``, ``state``, ``frames``, ``values`` (``names``), ``set`` (``name``,
``value``), ``detach``; answers are ``{"ok": true, ...}`` or ``{"ok": false, "error":
TEXT}``.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import os
import queue
import threading
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

from asictl.build import program_of_image
from asictl.debug.debugger import (
    Breakpoint,
    DebugError,
    Mode,
    Pause,
    Values,
    checked_hit_condition,
    due_breakpoint,
    line_with_code,
)
from asictl.debug.inventory import Inventory
from asictl.errors import UserError
from asictl.host.live.board import LiveBoard
from asictl.host.live.protocol import encode, read_message, socket_path
from asictl.il import ast
from asictl.il.ast import key
from asictl.image.eeprom import ImageError
from asictl.mcs51.isa import SFRS
from asictl.observe.hooks import LineHooks
from asictl.observe.locate import call_chain, current_line
from asictl.observe.operands import SETTABLE, Operand, image_symbols, parse_operand
from asictl.observe.symbols import SymbolTable
from asictl.observe.view import ProgramView, host_write, read_on_board, wake
from asictl.platform import pc2
from asictl.runtime.line_map import SourceLine

JSON = Any
_SP = SFRS["SP"]
#: The actions a held board turns away.
_WATCHING = frozenset({"lines"})
#: Stops a host causes (a stop command, a download): no fault of the program to show.
_HOST_STOPS = (pc2.StopReason.NOT_STARTED, pc2.StopReason.NO_PROGRAM)


def debug_socket_path(directory: Path, base: int) -> Path:
    """``pc2-300h.debug.sock`` beside the live board's ``pc2-300h.sock``."""
    return socket_path(directory, base).with_suffix(".debug.sock")


class OnlineDebugger:
    """One debugger holding one live board; made by ``attach``, ended by ``detach``."""

    def __init__(self, live: LiveBoard, symbols: SymbolTable, who: str = "a debugger") -> None:
        board = live.board
        runner, image = board.program, board.loaded_image
        if runner is None or image is None:
            raise DebugError(board.program_error or "the board has no program loaded")
        if not image.line_map:
            raise DebugError("the board's image has no line map (format version 1): "
                             "download it again with this asictl")
        if live.hold is not None:
            raise DebugError("another debugger holds this board")
        self.live, self.board, self.runner, self.image = live, board, runner, image
        #: the debugging client, as it named itself: ``asictl dap (pid 7)``
        self.who = who
        self.line_map = image.line_map
        self.variables = {name: v.size for name, v in runner.pmap.variables.items()}
        self.symbols = symbols
        self.values = Values(
            lambda: ProgramView(runner, functools.partial(read_on_board, board)), self._operand,
            self.variables, symbols)
        self.breakpoints: list[Breakpoint] = []
        self._number = 1
        self.mode = Mode.CONTINUE
        self.cycle = 0
        self.line: SourceLine | None = None
        #: why the program is paused (None while it runs)
        self.paused: Pause | None = None
        #: the latest stop the client has not asked about yet
        self.reported: Pause | None = None
        #: the session's end (the program was replaced): every later state says so
        self.ended: Pause | None = None
        self._interrupt = False
        self._next_sp = 0xFF
        self._stopped = board.control_state is not pc2.ControlState.RUNNING
        self._work: queue.Queue[float | None] = queue.Queue()
        self._done: queue.Queue[str] = queue.Queue()
        self._resumes: queue.Queue[bool] = queue.Queue()
        self.hooks = LineHooks(runner, self.line_map, on_line=self._on_line,
                               on_cycle_start=self._on_cycle_start)
        self._worker = threading.Thread(target=self._run, name="asictl-debug", daemon=True)
        self._worker.start()
        self.hooks.install()
        wake(board)  # the master skips cycles that repeat the last: the hooks need one
        live.hold = self
        live.changes.note("debugger attached", who)

    # ------------------------------------------------------------------ the hold

    def advance(self, ms: float) -> None:
        """From the server's loop: master time passes in the worker; while the program is
        paused, it stands still."""
        if self.paused is not None or not self._worker.is_alive():
            return
        self._work.put(ms)
        self._done.get()

    def refusal(self, action: str) -> str | None:
        if action in _WATCHING:
            return (f"a debugger holds this board ({self.who}): the program view shows no "
                    "values until it detaches")
        return None

    def halted(self) -> str | None:
        """``halted at breakpoint line 6 by asictl dap (pid 7)`` while the program is
        paused (at a breakpoint, after a step, or asked to pause); None while it runs."""
        pause = self.paused
        if pause is None:
            return None
        at = "at breakpoint " if pause.breakpoint is not None else "at "
        where = (f"{at}line {pause.line.line}" if pause.line is not None
                 else "between program cycles")
        return f"halted {where} by {self.who}"

    def _run(self) -> None:
        """The worker: runs the board for each slice the loop hands it."""
        while True:
            ms = self._work.get()
            if ms is None:
                return
            self.board.advance(ms)  # never raises: a program failure is a stop
            if self.board.program is not self.runner:  # a download replaced the program
                self.hooks.remove()
                self.live.hold = None  # the loop waits below: nothing else looks at it
                self.ended = self.reported = Pause("end", text="the board's program was "
                                                   "replaced")
                self._done.put("done")
                return
            self._check_stop()
            self._done.put("done")

    def _check_stop(self) -> None:
        board = self.board
        stopped = board.control_state is not pc2.ControlState.RUNNING
        if stopped and not self._stopped and board.stop_reason not in _HOST_STOPS:
            line = None
            if board.stop_reason in pc2.STOPS_AT_AN_ADDRESS:
                at = int.from_bytes(board.dpram[pc2.STOP_ADDRESS : pc2.STOP_ADDRESS + 2],
                                    "little")
                line = self.line_map.line_at(at) or current_line(self.runner.cpu,
                                                                 self.line_map)
            reason = board.stop_message or board.stop_reason.name
            text = f"{line}: {reason}" if line is not None else reason
            self.line = line
            self.reported = Pause("fault", line, text=text)
        self._stopped = stopped

    # ------------------------------------------------------------------ traps (worker)

    def _on_cycle_start(self) -> None:
        self.cycle += 1
        self.line = None
        if self.mode is Mode.CYCLE or self._interrupt:
            self.mode = Mode.STEP  # stop at the cycle's first line, never between cycles

    def _on_line(self, line: SourceLine, address: int) -> None:
        self.line = line
        hit = due_breakpoint(self.breakpoints, line, self.values.holds)
        mode = self.mode
        if (hit is not None or self._interrupt or mode is Mode.STEP
                or (mode in (Mode.NEXT, Mode.OUT) and self.runner.cpu.sfr[_SP] <= self._next_sp)):
            self._pause(Pause("line", line, hit))

    def _pause(self, pause: Pause) -> None:
        self._interrupt = False
        self.paused = self.reported = pause
        self._done.put("paused")
        self._resumes.get()  # until resumed or detached
        self.paused = None

    # ------------------------------------------------------------------ requests (loop)

    def resume(self, how: str) -> None:
        if self.ended is not None:
            return
        sp = self.runner.cpu.sfr[_SP]
        inside = self.line is not None and bool(call_chain(self.runner.cpu, self.line_map))
        modes = {"continue": Mode.CONTINUE, "stepIn": Mode.STEP, "next": Mode.NEXT,
                 "stepOut": Mode.OUT if inside else Mode.CYCLE, "stepCycle": Mode.CYCLE}
        if how not in modes:
            raise DebugError(f"resume how? one of {', '.join(modes)}")
        self.mode = modes[how]
        self._next_sp = sp - 2 if self.mode is Mode.OUT else (
            sp if self.line is not None else 0xFF)
        self.reported = None
        if self.paused is not None:
            self._resumes.put(True)
            self._done.get()  # the rest of the slice ran, or the program paused again
        self.live.rebase()

    def interrupt(self) -> None:
        self._interrupt = True

    def detach(self) -> None:
        """Let the program run on, as if no debugger had come."""
        self.breakpoints.clear()
        self.mode = Mode.CONTINUE
        self._interrupt = False
        if self.paused is not None:
            self._resumes.put(True)
            self._done.get()
        self.hooks.remove()
        self.live.hold = None
        self._work.put(None)
        self._worker.join(timeout=5)
        self.live.rebase()
        self.live.changes.note("debugger detached", self.who)

    def add_breakpoint(self, file: str, line: int, condition: str,
                       hit_condition: str) -> Breakpoint:
        at = line_with_code(self.line_map, file, line)
        if condition:
            self.values.condition(condition)
        point = Breakpoint(self._number, at, condition,
                           hit_condition=checked_hit_condition(hit_condition))
        self._number += 1
        return point

    def _operand(self, text: str) -> Operand:
        try:
            return parse_operand(text, self.variables, self.symbols)
        except ValueError as exc:
            raise DebugError(str(exc)) from None

    def frames(self) -> list[SourceLine]:
        line = self.line
        if line is None:
            return []
        callers = [c for c in call_chain(self.runner.cpu, self.line_map) if c != line]
        return [line, *reversed(callers)]

    def set(self, name: str, value: int) -> None:
        """An input as its slave delivers it, a flag as a host writes it."""
        operand = self._operand(name)
        if not operand.settable:
            raise DebugError(f"'{operand}' cannot be set: {SETTABLE}")
        if not 0 <= value <= operand.maximum:
            raise DebugError(f"value {value} out of range 0..{operand.maximum}")
        board, node = self.board, operand.node
        n, b, kind = node.address, node.bit, node.kind
        if kind is ast.OperandKind.I:
            for slave in self._slaves(n, name):
                slave.inputs = value if b < 0 else slave.inputs & ~(1 << b) | value << b
        elif kind is ast.OperandKind.IB:
            for address, nibble in ((n, value & 0xF), (n + 1, value >> 4)):
                for slave in self._slaves(address, name):
                    slave.inputs = nibble
        elif kind is ast.OperandKind.F:
            old = board.dpram_byte(pc2.FLAGS + n)
            host_write(board, pc2.FLAGS + n, old & ~(1 << b) | value << b)
        elif kind is ast.OperandKind.FY:
            host_write(board, pc2.FLAGS + n, value)
        else:
            raise DebugError(f"'{operand}' cannot be set")

    def _slaves(self, address: int, name: str) -> list[Any]:
        found = self.board.bus.at(address)
        if not found:
            raise DebugError(f"'{name}' sets slave {address}, which is not on the bus")
        return list(found)

    # ------------------------------------------------------------------ answers

    def describe(self) -> JSON:
        """What the client needs once: the files with code, their sources (when the image
        carries them), the operands to show."""
        sources = {name: raw.decode("latin-1").replace("\r\n", "\n")
                   for name, raw in self.image.program_sources().items()}
        try:
            program = program_of_image(self.image)
        except ImageError:
            program = None
        inventory = Inventory.of(self.image, program, self.symbols)
        return {"identity": self.image.identity_hex, "files": sorted(self.line_map.files),
                "sources": sources, "inventory": inventory.as_json()}

    def state(self) -> JSON:
        stop = self.ended or self.reported
        answer: dict[str, JSON] = {"running": self.paused is None, "cycle": self.cycle,
                                   "master_ms": self.board.now_ms, "stop": None}
        if stop is not None:
            answer["stop"] = {"kind": stop.kind, "text": stop.text,
                              "breakpoint": stop.breakpoint.number if stop.breakpoint else None}
        return answer

    def handle(self, request: JSON) -> JSON:
        op = request.get("op")
        if op == "breakpoints":
            file = str(request["file"])
            self.breakpoints = [b for b in self.breakpoints
                                if b.line.file.casefold() != file.casefold()]
            placed: list[JSON] = []
            for line, condition, hit in request["wanted"]:
                try:
                    point = self.add_breakpoint(file, int(line), str(condition), str(hit))
                except DebugError as exc:
                    placed.append([None, None, str(exc)])
                    continue
                self.breakpoints.append(point)
                placed.append([point.number, point.line.line, ""])
            return {"placed": placed}
        if op == "resume":
            self.resume(str(request["how"]))
            return {}
        if op == "interrupt":
            self.interrupt()
            return {}
        if op == "state":
            return self.state()
        halted = self.reported is not None and self.reported.kind == "fault"
        if self.paused is None and not halted and op in ("frames", "values", "set"):
            raise DebugError("the program is running: pause it first")
        if op == "frames":
            return {"frames": [[at.file, at.line] for at in self.frames()],
                    "constant": ProgramView(self.runner, lambda _: 0).constant}
        if op == "values":
            shown = []
            for name in request["names"]:
                try:
                    shown.append(self.values.show(str(name)))
                except DebugError as exc:
                    shown.append(f"({exc})")
            return {"values": shown}
        if op == "set":
            self.set(str(request["name"]), int(request["value"]))
            return {}
        raise DebugError(f"unknown request {op!r}")


# --------------------------------------------------------------------------- the socket


def debugging(path: Path) -> Callable[[LiveBoard], tuple[Awaitable[None], Callable[[], None]]]:
    """The debug socket at ``path`` for ``host.live.run_live``'s ``attach``."""

    def attach(live: LiveBoard) -> tuple[Awaitable[None], Callable[[], None]]:
        stop = asyncio.Event()
        return _serve(live, path, stop), stop.set

    return attach


async def _serve(live: LiveBoard, path: Path, stop: asyncio.Event) -> None:
    with contextlib.suppress(FileNotFoundError):
        path.unlink()  # ours: the server holds the board's lock
    old = os.umask(0o177)
    try:
        server = await asyncio.start_unix_server(
            functools.partial(_client, live), path=str(path))
    finally:
        os.umask(old)
    try:
        await stop.wait()
    finally:
        server.close()
        with contextlib.suppress(FileNotFoundError):
            path.unlink()
        await server.wait_closed()


async def _client(live: LiveBoard, reader: asyncio.StreamReader,
                  writer: asyncio.StreamWriter) -> None:
    """One debugging client: its requests in turn; its end detaches it."""
    debugger: OnlineDebugger | None = None
    try:
        while True:
            request = await read_message(reader)
            if request is None:
                break
            try:
                if not isinstance(request, dict):
                    raise DebugError("a request is a JSON object")
                if request.get("op") == "attach":
                    if debugger is None:
                        given = SymbolTable(entries={
                            key(str(name)): (str(name), str(operand))
                            for name, operand in request.get("symbols") or []})
                        # without a table of its own the client gets the board's, the
                        # one the download stored with the program
                        debugger = OnlineDebugger(
                            live, given or image_symbols(live.board.loaded_image),
                            str(request.get("who") or "a debugger"))
                    answer = {"ok": True, **debugger.describe()}
                elif debugger is None:
                    raise DebugError("attach first")
                elif request.get("op") == "detach":
                    debugger.detach()
                    debugger = None
                    answer = {"ok": True}
                else:
                    answer = {"ok": True, **debugger.handle(request)}
            except (DebugError, UserError) as exc:
                answer = {"ok": False, "error": str(exc), "exit": 1}
            except (KeyError, TypeError, ValueError) as exc:
                answer = {"ok": False, "error": f"malformed request: {exc!r}", "exit": 1}
            writer.write(encode(answer))
            await writer.drain()
    except (ConnectionError, asyncio.CancelledError):
        pass
    finally:
        if debugger is not None:
            debugger.detach()
        writer.close()
