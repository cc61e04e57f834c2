"""The debug adapter: Debug Adapter Protocol requests in, responses and events out.

The session runs as the protocol lays it down: ``initialize`` (the capabilities), then
``launch`` or ``attach`` (the program is loaded; the ``initialized`` event follows the
response), the breakpoints, ``configurationDone`` (the program starts), ``stopped``
events with the requests that look at a stopped program, and ``terminated`` at the end.
The adapter reads requests on one thread; a resumed program runs on another, so that a
``pause`` can reach it, and the requests that look at the program are refused while it
runs. Whatever a request does wrong is an error response, never the adapter's end.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from pathlib import Path, PurePath
from typing import Any, BinaryIO

from asictl import __version__
from asictl.dap.targets import HOW, Frame, Placed, Stop, Target, Variable, Wanted
from asictl.debug.debugger import DebugError
from asictl.errors import UserError
from asictl.lsp.framing import JSON, Malformed, Reader, Writer

#: The one thread: the control program.
THREAD = 1
#: The adapter's custom request: run to the first line of the next program cycle.
STEP_CYCLE = "stepCycle"

CAPABILITIES: dict[str, JSON] = {
    "supportsConfigurationDoneRequest": True,
    "supportsConditionalBreakpoints": True,
    "supportsHitConditionalBreakpoints": True,
    "supportsSetVariable": True,
    "supportsEvaluateForHovers": True,
    "supportsTerminateRequest": True,
    "supportTerminateDebuggee": True,
    "exceptionBreakpointFilters": [],
}

#: Builds a target from the request's arguments and the console; raises UserError.
Opener = Callable[[dict[str, JSON], Callable[[str], None]], Target]


class RequestError(Exception):
    """A request that cannot be done, in words for the user."""


class Adapter:
    """One debugging session over a pair of byte streams."""

    def __init__(self, requests: BinaryIO, replies: BinaryIO,
                 openers: dict[str, Opener]) -> None:
        self.reader = Reader(requests)
        self.writer = Writer(replies)
        self.openers = openers
        self.target: Target | None = None
        self._seq = 0
        self._seq_lock = threading.Lock()
        self._runner: threading.Thread | None = None
        self._variables: dict[int, list[Variable]] = {}
        self._frames: list[Frame] = []
        self._line_base = 1
        self._no_debug = False
        self._stop_on_entry = False
        self._done = False
        #: the program runs (set before its thread starts, cleared before its stop is told)
        self._busy = False

    # ------------------------------------------------------------------ the loop

    def serve(self) -> None:
        """Answer requests until ``disconnect`` or the end of the input."""
        try:
            while not self._done:
                message = self.reader.read()
                if message is None:
                    break
                if isinstance(message, Malformed):
                    self.output(f"asictl dap: skipped a malformed message: {message.why}\n",
                                "stderr")
                    continue
                self._dispatch(message)
        finally:
            self._end_target()

    def _dispatch(self, message: dict[str, JSON]) -> None:
        command = message.get("command")
        if message.get("type") != "request" or not isinstance(command, str):
            self.output("asictl dap: skipped a message that is not a request\n", "stderr")
            return
        arguments = message.get("arguments")
        if not isinstance(arguments, dict):
            arguments = {}
        handler = self._handlers().get(command)
        try:
            if handler is None:
                raise RequestError(f"asictl dap does not know the request '{command}'")
            body = handler(arguments)
        except (RequestError, DebugError, UserError) as exc:
            self._respond(message, False, message=str(exc))
            return
        except Exception as exc:  # a bug: the session goes on
            self._respond(message, False, message=(
                f"internal error (this is a bug in asictl {__version__}): "
                f"{type(exc).__name__}: {exc}"))
            return
        after = None
        if isinstance(body, tuple):
            body, after = body
        self._respond(message, True, body=body)
        if after is not None:
            after()

    def _handlers(self) -> dict[str, Callable[[dict[str, JSON]], Any]]:
        return {
            "initialize": self._initialize, "launch": self._launch, "attach": self._attach,
            "setBreakpoints": self._set_breakpoints,
            "setExceptionBreakpoints": lambda _: {"breakpoints": []},
            "configurationDone": self._configuration_done, "threads": self._threads,
            "stackTrace": self._stack_trace, "scopes": self._scopes,
            "variables": self._variables_of, "setVariable": self._set_variable,
            "evaluate": self._evaluate, "pause": self._pause, "source": self._source,
            "continue": self._resumer("continue"), "next": self._resumer("next"),
            "stepIn": self._resumer("stepIn"), "stepOut": self._resumer("stepOut"),
            STEP_CYCLE: self._resumer("stepCycle"),
            "disconnect": self._disconnect, "terminate": self._terminate,
        }

    # ------------------------------------------------------------------ sending

    def _next_seq(self) -> int:
        with self._seq_lock:
            self._seq += 1
            return self._seq

    def _respond(self, request: dict[str, JSON], success: bool, *, body: JSON = None,
                 message: str = "") -> None:
        reply: dict[str, JSON] = {
            "seq": self._next_seq(), "type": "response", "request_seq": request.get("seq", 0),
            "command": request.get("command", ""), "success": success,
        }
        if body is not None:
            reply["body"] = body
        if not success:
            reply["message"] = message
            reply["body"] = {"error": {"id": 1, "format": message, "showUser": True}}
        self.writer.write(reply)

    def event(self, name: str, body: JSON = None) -> None:
        message: dict[str, JSON] = {"seq": self._next_seq(), "type": "event", "event": name}
        if body is not None:
            message["body"] = body
        self.writer.write(message)

    def output(self, text: str, category: str = "console") -> None:
        self.event("output", {"category": category, "output": text})

    # ------------------------------------------------------------------ starting

    def _initialize(self, args: dict[str, JSON]) -> JSON:
        self._line_base = 1 if args.get("linesStartAt1", True) is not False else 0
        return CAPABILITIES

    def _open(self, kind: str, args: dict[str, JSON]) -> JSON:
        if self.target is not None:
            raise RequestError("this session already debugs a program")
        self._no_debug = args.get("noDebug") is True
        self._stop_on_entry = args.get("stopOnEntry") is True
        self.target = self.openers[kind](args, lambda text: self.output(text + "\n"))
        return None, lambda: self.event("initialized")

    def _launch(self, args: dict[str, JSON]) -> JSON:
        return self._open("launch", args)

    def _attach(self, args: dict[str, JSON]) -> JSON:
        return self._open("attach", args)

    def _configuration_done(self, args: dict[str, JSON]) -> JSON:
        target = self._need_target()
        if self._stop_on_entry and not self._no_debug:
            return None, lambda: self._run(target, "stepIn", entry=True)
        return None, lambda: self._run(target, "continue")

    def _need_target(self) -> Target:
        if self.target is None:
            raise RequestError("no program: launch or attach first")
        return self.target

    # ------------------------------------------------------------------ breakpoints

    def _set_breakpoints(self, args: dict[str, JSON]) -> JSON:
        target = self._need_target()
        given = args.get("source")
        source: dict[str, JSON] = given if isinstance(given, dict) else {}
        name = PurePath(str(source.get("path") or source.get("name") or "")).name
        wanted = []
        for entry in args.get("breakpoints") or []:
            if isinstance(entry, dict) and isinstance(entry.get("line"), int):
                wanted.append(Wanted(entry["line"] - self._line_base + 1,
                                     str(entry.get("condition") or ""),
                                     str(entry.get("hitCondition") or "")))
        if self._no_debug:
            placed = [Placed(None, message="running without debugging") for _ in wanted]
        elif not any(n.casefold() == name.casefold() for n in (*target.files, *target.sources)):
            placed = [Placed(None, message=f"{name} is not part of the program debugged")
                      for _ in wanted]
        else:
            placed = target.set_breakpoints(name, wanted)
        return {"breakpoints": [self._breakpoint(p, source) for p in placed]}

    def _breakpoint(self, placed: Placed, source: dict[str, JSON]) -> JSON:
        reply: dict[str, JSON] = {"verified": placed.verified, "source": source}
        if placed.number is not None:
            reply["id"] = placed.number
        if placed.line is not None:
            reply["line"] = placed.line + self._line_base - 1
        if placed.message:
            reply["message"] = placed.message
        return reply

    # ------------------------------------------------------------------ running

    def _resumer(self, how: str) -> Callable[[dict[str, JSON]], JSON]:
        assert how in HOW

        def resume(args: dict[str, JSON]) -> JSON:
            target = self._need_target()
            if self._running():
                raise RequestError("the program is running")
            body = {"allThreadsContinued": True} if how == "continue" else None
            return body, lambda: self._run(target, how)

        return resume

    def _running(self) -> bool:
        return self._busy

    def _run(self, target: Target, how: str, *, entry: bool = False) -> None:
        self._variables.clear()
        self._frames = []

        def run() -> None:
            try:
                stop = target.resume(how)
            except (DebugError, UserError) as exc:
                self.output(f"error: {exc}\n", "stderr")
                stop = Stop("end", exit_code=1)
            except Exception as exc:
                self.output(f"internal error (this is a bug in asictl {__version__}): "
                            f"{type(exc).__name__}: {exc}\n", "stderr")
                stop = Stop("end", exit_code=3)
            self._busy = False
            self._stopped(stop, entry)

        self._busy = True
        self._runner = threading.Thread(target=run, name="asictl-dap-run", daemon=True)
        self._runner.start()

    def _stopped(self, stop: Stop, entry: bool) -> None:
        if stop.reason == "end":
            self.event("exited", {"exitCode": stop.exit_code})
            self.event("terminated")
            return
        body: dict[str, JSON] = {"reason": "entry" if entry and stop.reason == "step"
                                 else stop.reason, "threadId": THREAD,
                                 "allThreadsStopped": True}
        if stop.description:
            body["description"] = stop.description
        if stop.text:
            body["text"] = stop.text
        if stop.breakpoints:
            body["hitBreakpointIds"] = list(stop.breakpoints)
        self.event("stopped", body)

    def _pause(self, args: dict[str, JSON]) -> JSON:
        target = self._need_target()
        if self._running():
            target.interrupt()
        return None

    # ------------------------------------------------------------------ looking

    def _stopped_target(self) -> Target:
        target = self._need_target()
        if self._running():
            raise RequestError("the program is running: pause it first")
        return target

    def _threads(self, args: dict[str, JSON]) -> JSON:
        return {"threads": [{"id": THREAD, "name": "control program"}]}

    def _stack_trace(self, args: dict[str, JSON]) -> JSON:
        target = self._stopped_target()
        self._frames = target.frames()
        frames = []
        for number, frame in enumerate(self._frames, start=1):
            entry: dict[str, JSON] = {"id": number, "name": frame.name, "line": 0, "column": 0}
            if frame.line is not None:
                entry["line"] = frame.line.line + self._line_base - 1
                entry["column"] = self._line_base
                entry["source"] = self._source_of(target, frame.line.file)
            frames.append(entry)
        start = args.get("startFrame") if isinstance(args.get("startFrame"), int) else 0
        levels = args.get("levels") if isinstance(args.get("levels"), int) else 0
        assert isinstance(start, int) and isinstance(levels, int)
        chosen = frames[start:start + levels] if levels > 0 else frames[start:]
        return {"stackFrames": chosen, "totalFrames": len(frames)}

    def _source_of(self, target: Target, name: str) -> JSON:
        """A file the editor opens by its path, or asks for (``source``) by reference."""
        source: dict[str, JSON] = {"name": name}
        path = target.files.get(name)
        if path is not None:
            source["path"] = str(path)
        elif name in target.sources:
            source["sourceReference"] = sorted(target.sources).index(name) + 1
        return source

    def _source(self, args: dict[str, JSON]) -> JSON:
        target = self._need_target()
        reference = args.get("sourceReference")
        if not isinstance(reference, int) and isinstance(args.get("source"), dict):
            reference = args["source"].get("sourceReference")
        names = sorted(target.sources)
        if not isinstance(reference, int) or not 0 < reference <= len(names):
            raise RequestError("no such source")
        return {"content": target.sources[names[reference - 1]], "mimeType": "text/x-asi"}

    def _scopes(self, args: dict[str, JSON]) -> JSON:
        target = self._stopped_target()
        self._variables.clear()
        found = []
        for reference, scope in enumerate(target.scopes(), start=1):
            self._variables[reference] = scope.variables
            found.append({"name": scope.name, "variablesReference": reference,
                          "expensive": False, "namedVariables": len(scope.variables)})
        return {"scopes": found}

    def _variables_of(self, args: dict[str, JSON]) -> JSON:
        self._stopped_target()
        variables = self._variables.get(args.get("variablesReference", 0), [])
        return {"variables": [self._variable(v) for v in variables]}

    @staticmethod
    def _variable(variable: Variable) -> JSON:
        reply: dict[str, JSON] = {"name": variable.name, "value": variable.value,
                                  "type": variable.kind, "variablesReference": 0,
                                  "evaluateName": variable.name}
        if not variable.settable:
            reply["presentationHint"] = {"attributes": ["readOnly"]}
        return reply

    def _set_variable(self, args: dict[str, JSON]) -> JSON:
        target = self._stopped_target()
        name, value = str(args.get("name", "")), str(args.get("value", ""))
        known = {v.name: v for v in self._variables.get(args.get("variablesReference", 0), [])}
        if name in known and not known[name].settable:
            raise RequestError(f"'{name}' cannot be set: only inputs (I, IB) and flags "
                               "(F, FY), directly or by their symbols")
        return {"value": target.assign(name, value)}

    def _evaluate(self, args: dict[str, JSON]) -> JSON:
        target = self._stopped_target()
        text = str(args.get("expression", "")).strip()
        if not text:
            raise RequestError("evaluate what? an operand such as I 1.0, FY 10, RLO")
        return {"result": target.evaluate(text), "variablesReference": 0}

    # ------------------------------------------------------------------ ending

    def _disconnect(self, args: dict[str, JSON]) -> JSON:
        self._done = True
        return None, self._end_target

    def _terminate(self, args: dict[str, JSON]) -> JSON:
        def end() -> None:
            self._end_target()
            self.event("terminated")

        return None, end

    def _end_target(self) -> None:
        target, self.target = self.target, None
        if target is None:
            return
        if self._runner is not None and self._runner.is_alive():
            target.interrupt()
            self._runner.join(timeout=10)
        target.close()


def resolve(args: dict[str, JSON], key: str) -> Path | None:
    """A path argument, relative to the configuration's ``cwd`` if it gives one."""
    value = args.get(key)
    if value in (None, ""):
        return None
    cwd = args.get("cwd")
    base = Path(_path_text(args, "cwd")) if isinstance(cwd, str) and cwd else Path(os.getcwd())
    return base / Path(_path_text(args, key)).expanduser()


def _path_text(args: dict[str, JSON], key: str) -> str:
    """A path argument's text, refused (a request error) where no file system could take
    it: a NUL byte, or a lone surrogate that no file name encodes (JSON lets an editor
    send ``"\\ud800"``); either would fail deep in ``open`` as an internal error."""
    value = args.get(key)
    if not isinstance(value, str):
        raise UserError(f"'{key}' must be a path, not {value!r}")
    if "\0" in value:
        raise UserError(f"'{key}' is not a path: it holds a NUL character")
    try:
        os.fsencode(value)
    except UnicodeError:
        raise UserError(f"'{key}' is not a path: it holds a character no file name "
                        f"can have ({value!a})") from None
    return value
