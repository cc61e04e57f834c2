"""``launch``: the IL debugger (``debug.debugger``) on a simulation, as a target.

Everything goes through the debugger's own commands and public methods, so an editor's
session and ``asictl debug`` behave alike: a step is the debugger's ``step``, a value is
what its ``print`` shows, a written value goes through its ``set``. The debugger's
report of each command goes to the editor's console.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path, PurePath

from asictl.dap.adapter import resolve
from asictl.dap.targets import Frame, Placed, Scope, Stop, Wanted
from asictl.dap.variables import scopes
from asictl.debug.debugger import DebugError, Debugger, Pause
from asictl.debug.inventory import Inventory
from asictl.errors import UserError
from asictl.lsp.framing import JSON
from asictl.observe.locate import call_chain
from asictl.readers.units import UnitError, format_instant
from asictl.readers.units import duration_ms as read_duration
from asictl.runtime.line_map import SourceLine
from asictl.sim.engine import source_texts
from asictl.sim.scenario import MAX_TIME_MS
from asictl.sim.session import Invalid, Prepared, prepare, scenario_for

#: Console commands that only look (the others run the program, which the editor's
#: buttons do).
_LOOKING = ("p", "print", "set", "w", "where", "l", "list", "breaks", "info", "help", "h")
#: The debugger's command for each way of resuming.
_COMMAND = {"continue": "continue", "stepIn": "step", "next": "next", "stepOut": "finish"}


class SimulatedTarget:
    """A launched program on an emulated master in virtual time."""

    def __init__(self, prepared: Prepared, out: Callable[[str], None]) -> None:
        self.out = out
        self.debugger = Debugger(prepared, out)
        build = prepared.build
        self.files = {PurePath(name).name: Path(name).resolve() for name in build.texts}
        self.files.setdefault(PurePath(prepared.program).name, Path(prepared.program).resolve())
        #: an image's own source (a .hex or uploaded file), shown by reference
        self.sources = {name: text for name, text in source_texts(build).items()
                        if name not in self.files or not self.files[name].is_file()}
        for name in self.sources:
            self.files.pop(name, None)
        assert build.image is not None  # prepare() refuses a build without one
        self.inventory = Inventory.of(build.image, build.source_program(), prepared.symbols)
        self._interrupted = False

    # ------------------------------------------------------------------ breakpoints

    def set_breakpoints(self, file: str, wanted: list[Wanted]) -> list[Placed]:
        debugger = self.debugger
        debugger.breakpoints = [b for b in debugger.breakpoints
                                if b.line.file.casefold() != file.casefold()]
        placed = []
        for want in wanted:
            try:
                point = debugger.add_breakpoint(f"{file}:{want.line}", want.condition.strip(),
                                                want.hit_condition.strip())
            except DebugError as exc:
                placed.append(Placed(None, message=str(exc)))
                continue
            placed.append(Placed(point.number, point.line.line))
        return placed

    # ------------------------------------------------------------------ running

    def resume(self, how: str) -> Stop:
        debugger = self.debugger
        self._interrupted = False
        if how == "stepOut" and (debugger.line is None
                                 or not call_chain(debugger.runner.cpu, debugger.line_map)):
            how = "stepCycle"  # out of the main program: into the next cycle
        if how == "stepCycle":
            self._run("cycle")
            if self._at_cycle_start():
                self._run("step")
        else:
            self._run(_COMMAND[how])
            if self._at_cycle_start():  # paused between cycles: show the next line
                self._run("step")
        return self._stop(how)

    def _run(self, command: str) -> None:
        self.debugger.execute(command)

    def _at_cycle_start(self) -> bool:
        pause = self.debugger.pause
        return pause is not None and pause.kind == "cycle" and not self.debugger.ended

    def _stop(self, how: str) -> Stop:
        debugger = self.debugger
        pause: Pause | None = debugger.pause
        if pause is None or pause.kind in ("end", "error") or debugger.ended:
            result = debugger.sim.result
            failed = bool(result.failures or result.stops) or (pause is not None
                                                               and pause.kind == "error")
            return Stop("end", exit_code=int(failed))
        if pause.kind == "fault":
            return Stop("exception", "program stopped", pause.text)
        if pause.breakpoint is not None:
            return Stop("breakpoint", breakpoints=(pause.breakpoint.number,))
        if self._interrupted:
            return Stop("pause")
        return Stop("step")

    def interrupt(self) -> None:
        self._interrupted = True
        self.debugger.interrupt()

    # ------------------------------------------------------------------ looking

    def frames(self) -> list[Frame]:
        debugger = self.debugger
        line = debugger.line
        if line is None:
            return [Frame(f"between cycles, master time {format_instant(debugger.now())}", None)]
        callers = [c for c in call_chain(debugger.runner.cpu, debugger.line_map) if c != line]
        return [Frame(self._name(at, debugger.cycle), at) for at in [line, *reversed(callers)]]

    def _name(self, line: SourceLine, cycle: int) -> str:
        if line.file.casefold() == self.debugger.main_file.casefold():
            return f"{line.file} (cycle {cycle})"
        return f"FB {line.file}"

    def scopes(self) -> list[Scope]:
        view = self.debugger.sim.view()
        return scopes(self.inventory, self._show, view.constant)

    def _show(self, names: list[str]) -> list[str]:
        shown = []
        for name in names:
            try:
                shown.append(self.debugger.show(name))
            except DebugError as exc:
                shown.append(f"({exc})")
        return shown

    def evaluate(self, text: str) -> str:
        verb = text.strip().partition(" ")[0].lower()
        if verb in _LOOKING:
            lines: list[str] = []
            self._capture(lines, text)
            return "\n".join(lines)
        try:
            return self.debugger.show(text)
        except DebugError as exc:
            raise DebugError(f"{exc} (the console also takes the debugger's commands "
                             "print, set, where, list, breaks, help)") from None

    def assign(self, name: str, value: str) -> str:
        lines: list[str] = []
        if not self._capture(lines, f"set {name}={value}"):
            raise DebugError("; ".join(line.removeprefix("error: ") for line in lines))
        return value.strip()

    def _capture(self, lines: list[str], command: str) -> bool:
        """Run a looking command with its report kept; whether it was done."""
        debugger = self.debugger
        out, failed = debugger.out, debugger.failed
        debugger.out, debugger.failed = lines.append, False
        try:
            debugger.execute(command)
            return not debugger.failed
        finally:
            debugger.out, debugger.failed = out, failed

    def close(self) -> None:
        self.debugger.close()


def launch(args: dict[str, JSON], out: Callable[[str], None]) -> SimulatedTarget:
    """``launch``'s arguments as ``asictl debug`` takes them: ``program``, ``scenario``
    (default: the one beside the program; ``noScenario``), ``set`` (``"I 1.0=1"``...),
    ``duration``, ``lib``."""
    program = resolve(args, "program")
    scenario = resolve(args, "scenario")
    if program is None and scenario is None:
        raise UserError("launch needs a 'program' (or a 'scenario' that names one)")
    if scenario is None and program is not None and args.get("noScenario") is not True \
            and scenario_for(program).is_file():
        scenario = scenario_for(program)
    duration = args.get("duration")
    try:
        duration_ms = (read_duration(duration, limit_ms=MAX_TIME_MS)
                       if duration not in (None, "") else None)
    except UnitError as exc:
        raise UserError(f"duration: {exc}") from None
    try:
        prepared = prepare(program, scenario, lib=_strings(args, "lib"),
                           sets=_strings(args, "set"), duration_ms=duration_ms,
                           allow_partial=True)
    except Invalid as exc:
        out(exc.text.rstrip("\n"))
        raise UserError(f"{exc.message} (the debug console shows why)") from None
    if prepared.notes:
        out(prepared.notes.rstrip("\n"))
    if scenario is not None:
        out(f"scenario {scenario}")
    return SimulatedTarget(prepared, out)


def _strings(args: dict[str, JSON], key: str) -> list[str]:
    value = args.get(key)
    if value is None:
        return []
    if isinstance(value, str):
        return [value]
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise UserError(f"'{key}' must be a list of strings, not {value!r}")
    return value
