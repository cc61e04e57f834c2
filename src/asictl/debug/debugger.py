"""The IL debugger: breakpoints on IL lines, stepping, and the program's values, on the
emulated master in virtual time (docs/debugging.md).

The program runs exactly as in ``asictl sim`` (same board, same download, same scenario
steps); the debugger watches it through traps at the line map's boundaries
(``observe.hooks``). A pause happens inside a trap, deep inside the emulator's run, so the
simulation runs in a worker thread: at a pause the worker reports to the debugger and
waits for the next command; the debugger reads the machine while the worker waits. Only
one of the two threads ever runs at a time.
"""

from __future__ import annotations

import queue
import re
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import Enum
from pathlib import PurePath

from asictl.il import ast
from asictl.mcs51.isa import SFRS
from asictl.observe.condition import Condition, ConditionError, parse_condition
from asictl.observe.hooks import LineHooks
from asictl.observe.iltrace import line_operands
from asictl.observe.locate import call_chain, current_line, describe
from asictl.observe.operands import (
    SETTABLE,
    Operand,
    parse_assignment,
    parse_operand,
)
from asictl.observe.symbols import SymbolTable
from asictl.observe.view import ProgramView
from asictl.platform.pc2 import STOP_ADDRESS, STOPS_AT_AN_ADDRESS
from asictl.readers.units import (
    TICK_MS,
    UnitError,
    format_duration,
    format_instant,
    parse_duration,
)
from asictl.runtime.line_map import LineMap, SourceLine
from asictl.sim.engine import Simulation, source_texts, variables_of
from asictl.sim.session import Prepared

_SP = SFRS["SP"]
#: Master time the worker runs at a time between looks at its target.
_SLICE_MS = 1.0
_COMPARE: dict[str, Callable[[int, int], bool]] = {
    "=": lambda a, b: a == b, "==": lambda a, b: a == b, "!=": lambda a, b: a != b,
    "<": lambda a, b: a < b, ">": lambda a, b: a > b, "<=": lambda a, b: a <= b,
    ">=": lambda a, b: a >= b,
}
#: A hit count condition as editors write them: ``3`` (from the third hit on, as ``>= 3``),
#: ``= 3`` (the third only), ``> 3``, ``< 3``, ``<= 3``, ``% 3`` (every third).
_HIT_CONDITION = re.compile(r"^\s*(==|=|>=|<=|>|<|%)?\s*(\d+)\s*$")
#: The IL machine's registers as ``print`` and conditions name them, and where the
#: program view has each (KREG: the 12-bit constant register of L KT, L KC and L KP).
_REGISTERS = {"RLO": "rlo", "ACCU1": "accu1", "ACCU2": "accu2", "KREG": "constant"}
#: The commands that end the session.
_QUIT = ("q", "quit", "exit")
#: What ends a word at the prompt: Tab completes the word after the last of these.
WORD_BREAKS = " \t,=()<>!"
#: Which of them a condition may name alone (a bit).
_REGISTER_BITS = {name: name == "RLO" for name in _REGISTERS}

HELP = """\
break LINE | FILE:LINE [if CONDITION]   stop before an IL line (b)
delete [N]                  remove breakpoint N (all without N)
breaks                      list the breakpoints
step                        run one IL line, into function blocks (s)
next                        run one IL line, over function block calls (n)
finish                      run out of the function block to its caller's next line
continue                    run to a breakpoint or the end (c)
cycle                       run to the start of the next program cycle
time DURATION               let master time pass (e.g. time 100ms, time 2s)
print X[, Y...]             I 1.0, FY 10, T 0, C 0, CV 0, TV 1, RLO, ACCU1, KREG, a symbol (p)
display [X[, Y...]]         print X at every stop from now on (without X: list them)
undisplay [N]               stop displaying expression N (all without N)
set OPERAND=VALUE           set an input or a flag (e.g. set I 1.0=1)
where                       the current line and its callers (w)
list                        the source around the current line (l)
quit                        end (q)"""


class Mode(Enum):
    CONTINUE = "continue"
    STEP = "step"
    NEXT = "next"
    OUT = "finish"
    CYCLE = "cycle"
    TIME = "time"


@dataclass
class Breakpoint:
    number: int
    line: SourceLine
    condition: str = ""
    hits: int = 0
    #: stop only at the hits this allows (``_HIT_CONDITION``); every hit when empty
    hit_condition: str = ""

    def due(self) -> bool:
        """Whether the hit just counted stops the program."""
        match = _HIT_CONDITION.match(self.hit_condition)
        if not self.hit_condition or match is None:
            return True
        op, number = match[1] or ">=", int(match[2])
        if op == "%":
            return number > 0 and self.hits % number == 0
        return _COMPARE[op](self.hits, number)


class _Quit(BaseException):
    """Unwinds the worker when the debugger ends while the program is paused. Not an
    ``Exception``: the board turns any ``Exception`` out of a program cycle into a stop
    of the program (``Pc2Board.advance`` never lets one out), and the worker would then
    wait at that stop for a command that never comes."""


@dataclass
class Pause:
    """Why the worker stopped: at a line, at a cycle start, at a time, where the program
    stopped (a cycle time-out, a fault), or at the end."""

    kind: str  # line, cycle, time, fault, end, error
    line: SourceLine | None = None
    breakpoint: Breakpoint | None = None
    text: str = ""


class DebugError(ValueError):
    """A command the debugger cannot do, in words for the user."""


class ConditionRefused(DebugError):
    """A breakpoint condition that does not read: the message, then the condition and a
    caret under the offending part (what the debugger prints after ``error:``, and the
    message an editor shows beside a refused breakpoint)."""

    def __init__(self, text: str, error: ConditionError) -> None:
        super().__init__("\n".join([error.message, *error.caret(text)]))
        self.error = error


@dataclass
class Values:
    """Registers and operands as the program sees them now, through ``view``: what
    ``print`` shows and breakpoint conditions compare, on a simulation or a live board."""

    view: Callable[[], ProgramView]
    #: an operand's text (or symbol) to the operand; raises DebugError
    operand: Callable[[str], Operand]
    #: the program's variables and symbols, as conditions read them
    variables: Mapping[str, int]
    symbols: SymbolTable | None
    _conditions: dict[str, Condition] = field(default_factory=dict)

    def value(self, text: str) -> int:
        view = self.view()
        upper = text.strip().upper()
        if upper in _REGISTERS:
            return int(getattr(view, _REGISTERS[upper]))
        return view.read(self.operand(text))

    def show(self, text: str) -> str:
        """A value as people read it: bytes also in hex, timers and counters with their
        remaining time and count."""
        view = self.view()
        upper = text.strip().upper()
        if upper == "RLO":
            return str(view.rlo)
        if upper in ("ACCU1", "ACCU2"):
            word = self.value(upper)
            return f"{word} ({word:04X}h)"
        if upper == "KREG":
            k = view.constant
            return (f"{k} ({k:03X}h; as L KT {k} ticks, {format_duration(k * TICK_MS)}, "
                    f"as L KC {k}, as L KP {k >> 4 & 0x1F}.{k & 0xF})")
        operand = self.operand(text)
        value = view.read(operand)
        node = operand.node
        if operand.is_bit and node.kind is ast.OperandKind.T:
            return f"{value} (remaining {format_duration(view.timer_ms(node.address) or 0)})"
        if operand.is_bit and node.kind is ast.OperandKind.C:
            return f"{value} (value {view.counter(node.address) or 0})"
        if node.width is not ast.Width.BYTE:  # a bit, CV n, TV n
            return str(value)
        return f"{value} ({value:02X}h)"

    def condition(self, text: str) -> Condition:
        """A breakpoint condition in the one condition language (docs/conditions.md),
        over operands, symbols and the registers; read once per text."""
        if text not in self._conditions:
            try:
                self._conditions[text] = parse_condition(text, self.variables, self.symbols,
                                                         registers=_REGISTER_BITS)
            except ConditionError as exc:
                raise ConditionRefused(text, exc) from None
        return self._conditions[text]

    def holds(self, text: str) -> bool:
        """Whether a breakpoint condition holds now."""
        view = self.view()
        return self.condition(text)(view.read, lambda name: int(getattr(view, _REGISTERS[name])))


def line_with_code(line_map: LineMap, file: str, wanted: int) -> SourceLine:
    """Line ``wanted`` of ``file``, or for a line without code (a label, a comment) the
    next one with code."""
    lines = [line for line in line_map.lines() if line.file.casefold() == file.casefold()]
    if not lines:
        known = ", ".join(line_map.files) or "none"
        raise DebugError(f"no code from '{file}' (files with code: {known})")
    later = [line for line in lines if line.line >= wanted]
    if not later:
        raise DebugError(f"{file} has no code at or after line {wanted}")
    return later[0]


def checked_hit_condition(text: str) -> str:
    """A hit count condition as ``Breakpoint.due`` reads it (refused here, not at a hit)."""
    if text and not _HIT_CONDITION.match(text):
        raise DebugError(f"hit count '{text}': a number of hits such as 3, = 3, > 3 or % 3")
    return text


def due_breakpoint(
    breakpoints: list[Breakpoint], line: SourceLine, holds: Callable[[str], bool]
) -> Breakpoint | None:
    """The breakpoint that stops the program at ``line`` now, counting its hits."""
    for point in breakpoints:
        if point.line == line and (not point.condition or holds(point.condition)):
            point.hits += 1
            if point.due():
                return point
    return None


class Debugger:
    """One debugging session; ``execute(command)`` returns False once it has ended."""

    def __init__(self, prepared: Prepared, out: Callable[[str], None]) -> None:
        self.prepared = prepared
        self.out = out
        self.sim = Simulation(prepared.build, prepared.scenario, duration_ms=prepared.end_ms,
                              symbols=prepared.symbols)
        self.symbols = prepared.symbols
        self.line_map = self.sim.line_map
        self.texts = {name: text.split("\n") for name, text in
                      source_texts(prepared.build).items()}
        self.main_file = PurePath(prepared.program).name
        self.breakpoints: list[Breakpoint] = []
        self._next_number = 1
        #: ``display``'s expressions, printed at every stop, as gdb's display does
        self.displays: list[str] = []
        self.sim.load()
        runner = self.sim.runner
        if runner is None:
            raise DebugError("the master did not load the program")
        self.runner = runner
        self.values = Values(self.sim.view, self._operand, variables_of(runner.pmap),
                             self.symbols)
        #: the operands the program's lines work on, for Tab to complete
        self._used = list({str(o): o for o in line_operands(self.sim.program).values()}
                          .values())
        self.hooks = LineHooks(runner, self.line_map, on_line=self._on_line,
                               on_cycle_start=self._on_cycle_start)
        self.hooks.install()
        self.cycle = 0
        self.line: SourceLine | None = None  # where the program is paused
        self.ended = False
        self._mode = Mode.CONTINUE
        self._target = 0.0
        self._next_sp = 0
        self._interrupt = False
        self._commands: queue.Queue[tuple[Mode, float] | None] = queue.Queue()
        self._pauses: queue.Queue[Pause] = queue.Queue()
        self._worker: threading.Thread | None = None
        self._reported = (0, 0)
        #: the latest stop (None before the program first ran)
        self.pause: Pause | None = None
        self._stops_seen = 0
        #: a command was refused (for --batch's exit status)
        self.failed = False
        self.out(f"{self.main_file}: loaded at master time 0, before the first cycle; "
                 f"{len(self.line_map.lines())} IL lines with code. 'help' lists the commands.")

    # ------------------------------------------------------------------ commands

    def execute(self, text: str) -> bool:
        """Run one command; False when the session has ended (quit)."""
        command, _, rest = text.strip().partition(" ")
        rest = rest.strip()
        verb = command.lower()
        try:
            if not verb:
                return True
            if verb in _QUIT:
                self.close()
                return False
            handler = self._handlers().get(verb)
            if handler is None:
                raise DebugError(f"unknown command '{command}' ('help' lists them)")
            handler(rest)
        except DebugError as exc:
            self.out(f"error: {exc}")
            self.failed = True
        return True

    def _handlers(self) -> dict[str, Callable[[str], None]]:
        """Each command (and its short name) with what does it; ``quit`` aside."""
        return {
            "b": self._break, "break": self._break, "delete": self._delete,
            "d": self._delete, "breaks": self._list_breaks, "info": self._list_breaks,
            "s": self._step, "step": self._step, "n": self._next, "next": self._next,
            "finish": self._finish,
            "c": self._continue, "continue": self._continue, "cycle": self._cycle,
            "time": self._time, "p": self._print, "print": self._print,
            "display": self._display, "undisplay": self._undisplay,
            "set": self._set, "w": self._where, "where": self._where,
            "l": self._list, "list": self._list, "help": self._help, "h": self._help,
        }

    def completions(self, before: str) -> list[str]:
        """What Tab offers for the word that ends ``before`` (the line up to the cursor;
        words end at ``WORD_BREAKS``): the commands' names for the first word; after
        ``break`` the program's files (``count.asi:``), then ``if`` and, in a condition,
        what names a value; after ``print``, ``display`` and ``set`` what names a value
        (``set``: what can be set). What names a value: the registers, the symbols, the
        kinds of operand the program uses and, after a kind (``Q``), the addresses of
        that kind it uses (``31.0``)."""
        *head, word = re.split(f"[{re.escape(WORD_BREAKS)}]", before.lstrip())
        if not head:
            found = [verb for verb in [*self._handlers(), *_QUIT] if len(verb) > 1]
        else:
            verb, given = head[0].lower(), [w for w in head if w]
            previous = given[-1] if given else ""
            if verb in ("b", "break") and "if" in given[1:]:
                found = [*self._names(previous, settable=False), "and", "or", "not"]
            elif verb in ("b", "break"):
                files = {f"{line.file}:" for line in self.line_map.lines()}
                found = list(files) if len(given) == 1 else ["if"]
            elif verb in ("p", "print", "display", "set"):
                found = self._names(previous, settable=verb == "set")
            else:
                found = []
        return sorted({f for f in found if f.casefold().startswith(word.casefold())})

    def _names(self, previous: str, *, settable: bool) -> list[str]:
        """What names a value (``completions``): after a kind of operand, its addresses
        in the program; else registers (not to set), symbols and the kinds."""
        used = [str(o).partition(" ") for o in self._used if o.settable or not settable]
        kind_given = previous.upper()
        if kind_given in {"CV", "TV", *ast.OperandKind.__members__}:
            return [address for kind, _, address in used if kind == kind_given]
        symbols = [name for name, text in self.symbols.entries.values()
                   if not settable or self._operand(text).settable]
        return [*([] if settable else _REGISTERS), *symbols, *(kind for kind, _, _ in used)]

    def _help(self, _: str) -> None:
        self.out(HELP)

    def _break(self, rest: str) -> None:
        where, _, condition = rest.partition(" if ")
        if not where.strip():
            raise DebugError("break LINE or break FILE:LINE [if CONDITION]")
        point = self.add_breakpoint(where.strip(), condition.strip())
        line = point.line
        self.out(f"breakpoint {point.number} at {line}"
                 + (f" if {point.condition}" if point.condition else "")
                 + f": {self._source(line)}")

    def add_breakpoint(
        self, where: str, condition: str = "", hit_condition: str = ""
    ) -> Breakpoint:
        """A breakpoint at ``12`` or ``latch.fb:12`` (a line without code: the next one
        with code); the condition and hit condition are checked now, not at the first hit."""
        line = self._resolve_line(where)
        if condition:
            self.values.condition(condition)
        point = Breakpoint(self._next_number, line, condition,
                           hit_condition=checked_hit_condition(hit_condition))
        self._next_number += 1
        self.breakpoints.append(point)
        return point

    def _resolve_line(self, text: str) -> SourceLine:
        file, _, number = text.rpartition(":")
        number = number.strip()  # 'count.asi: 12', as Tab completes the file
        file = PurePath(file).name if file else self.main_file
        if not (number.isascii() and number.isdigit()):  # not '²', which int() refuses
            raise DebugError(f"'{text}' is not a line: 12 or {self.main_file}:12")
        return line_with_code(self.line_map, file, int(number))

    def _delete(self, rest: str) -> None:
        if not rest:
            self.breakpoints.clear()
            self.out("all breakpoints deleted")
            return
        if not (rest.isascii() and rest.isdigit()) or not any(
            b.number == int(rest) for b in self.breakpoints
        ):
            raise DebugError(f"no breakpoint {rest}")
        self.breakpoints = [b for b in self.breakpoints if b.number != int(rest)]
        self.out(f"breakpoint {rest} deleted")

    def _list_breaks(self, _: str) -> None:
        if not self.breakpoints:
            self.out("no breakpoints")
        for b in self.breakpoints:
            condition = f" if {b.condition}" if b.condition else ""
            self.out(f"{b.number}: {b.line}{condition} (hit {b.hits} times)")

    def _step(self, _: str) -> None:
        self._resume(Mode.STEP)

    def _next(self, _: str) -> None:
        self._next_sp = self.runner.cpu.sfr[_SP] if self.line is not None else 0xFF
        self._resume(Mode.NEXT)

    def _finish(self, _: str) -> None:
        if self.line is None or not call_chain(self.runner.cpu, self.line_map):
            raise DebugError("not inside a function block: finish runs out of one")
        self._next_sp = self.runner.cpu.sfr[_SP] - 2  # the caller's level: one return less
        self._resume(Mode.OUT)

    def _continue(self, _: str) -> None:
        self._resume(Mode.CONTINUE)

    def _cycle(self, _: str) -> None:
        self._resume(Mode.CYCLE)

    def _time(self, rest: str) -> None:
        text = rest.strip()
        try:
            ms = parse_duration(text)
        except UnitError as exc:
            raise DebugError(str(exc)) from None
        self._resume(Mode.TIME, self.now() + ms)

    def _print(self, rest: str) -> None:
        if not rest:
            raise DebugError("print what? e.g. print I 1.0, FY 10, C 0, RLO")
        for item in (part.strip() for part in rest.split(",")):
            self.out(f"{item} = {self.show(item)}")

    def _display(self, rest: str) -> None:
        if not rest:
            if not self.displays:
                self.out("nothing displayed: display X[, Y...] adds to the list")
            self._show_displays()
            return
        items = [part.strip() for part in rest.split(",") if part.strip()]
        for item in items:
            self.show(item)  # a mistake now, not at every stop
        self.displays += items
        self._show_displays(items)

    def _undisplay(self, rest: str) -> None:
        if not rest:
            self.displays.clear()
            self.out("nothing displayed")
            return
        if not (rest.isascii() and rest.isdigit()) or not 1 <= int(rest) <= len(self.displays):
            raise DebugError(f"no display {rest}")
        self.out(f"display {rest} ({self.displays.pop(int(rest) - 1)}) removed")

    def _show_displays(self, items: list[str] | None = None) -> None:
        """``N: X = value`` for each displayed expression (or just the ``items`` given)."""
        for number, item in enumerate(self.displays, 1):
            if items is None or item in items:
                self.out(f"{number}: {item} = {self.show(item)}")

    def _set(self, rest: str) -> None:
        try:
            assignment = parse_assignment(rest, variables_of(self.runner.pmap), self.symbols)
            if not assignment.operand.settable:
                raise ValueError(f"'{assignment.operand}' cannot be set: {SETTABLE}")
            self.sim.set(assignment.operand, assignment.value)
        except ValueError as exc:
            raise DebugError(str(exc)) from None
        self.out(f"{assignment.written} = {assignment.value} "
                 "(the program sees it from its next cycle)")

    def _where(self, _: str) -> None:
        self.out(self._position())

    def _list(self, _: str) -> None:
        line = self.line
        if line is None:
            raise DebugError("not at a line (the program is between cycles)")
        lines = self.texts.get(line.file, [])
        for number in range(max(1, line.line - 4), min(len(lines), line.line + 4) + 1):
            marker = "=>" if number == line.line else "  "
            self.out(f"{marker}{number:5} | {lines[number - 1].rstrip()}")

    # ------------------------------------------------------------------ values

    def now(self) -> float:
        return self.sim.now_ms() if self.sim.started else 0.0

    def _operand(self, text: str) -> Operand:
        try:
            return parse_operand(text, variables_of(self.runner.pmap), self.symbols)
        except ValueError as exc:
            raise DebugError(str(exc)) from None

    def value(self, text: str) -> int:
        """A register (RLO, ACCU1, ACCU2, KREG) or an operand, as the program sees it now."""
        return self.values.value(text)

    def show(self, text: str) -> str:
        """A value as ``print`` shows it."""
        return self.values.show(text)

    def _condition(self, text: str) -> bool:
        return self.values.holds(text)

    # ------------------------------------------------------------------ running

    def _resume(self, mode: Mode, target: float | None = None) -> None:
        if self.ended:
            raise DebugError("the simulation has ended (at "
                             f"{format_instant(self.sim.end_ms)}); quit, or start again")
        end = self.sim.end_ms
        goal = end if target is None else min(target, end)
        if self._worker is None:
            self._worker = threading.Thread(target=self._work, daemon=True)
            self._worker.start()
        self._commands.put((mode, goal))
        self._wait()

    def _wait(self) -> None:
        while True:
            try:
                pause = self._pauses.get(timeout=0.2)
            except queue.Empty:
                continue
            except KeyboardInterrupt:
                self._interrupt = True
                continue
            break
        self.pause = pause
        self._report_events()
        self._report(pause)
        if pause.kind != "error":
            self._show_displays()

    def interrupt(self) -> None:
        """Pause at the next line (Ctrl-C while the program runs)."""
        self._interrupt = True

    def _work(self) -> None:
        """The worker thread: runs the simulation, pausing inside traps."""
        sim = self.sim
        try:
            first = self._commands.get()
            if first is None:
                return
            self._mode, self._target = first
            sim.begin()
            while True:
                while not self.ended and sim.now_ms() < self._target:
                    # in slices, so that a pause may set a nearer target (time 5ms)
                    slice_end = (sim.now_ms() // _SLICE_MS + 1) * _SLICE_MS
                    sim.run_to(min(self._target, slice_end))
                    self._pause_at_stop()
                if sim.now_ms() >= sim.end_ms:
                    self.ended = True
                    self.line = None
                    self._pauses.put(Pause("end"))
                    return
                self.line = None
                self._pause(Pause("time"))
        except _Quit:
            return
        except Exception as exc:
            self.ended = True
            self._pauses.put(Pause("error", text=f"{type(exc).__name__}: {exc}"))

    def _pause_at_stop(self) -> None:
        """In the worker: the program stopped (a cycle time-out, a fault) since the last
        look: pause there, at the line it names."""
        stops = self.sim.result.stops
        if len(stops) == self._stops_seen:
            return
        self._stops_seen = len(stops)
        stop = stops[-1]
        board = self.sim.board
        line = None
        if board.stop_reason in STOPS_AT_AN_ADDRESS:
            stop_at = board.dpram[STOP_ADDRESS : STOP_ADDRESS + 2]
            line = self.line_map.line_at(int.from_bytes(stop_at, "little")) or current_line(
                self.runner.cpu, self.line_map)
        self.line = line
        self._pause(Pause("fault", line, text=stop.text))

    def _pause(self, pause: Pause) -> None:
        """In the worker: report, then wait for the next command."""
        self._interrupt = False
        self._pauses.put(pause)
        command = self._commands.get()
        if command is None:
            raise _Quit
        self._mode, target = command
        self._target = max(target, self.sim.now_ms())

    def _on_cycle_start(self) -> None:
        self.cycle += 1
        self.line = None
        if self._mode is Mode.CYCLE or self._interrupt:
            self._pause(Pause("cycle"))

    def _on_line(self, line: SourceLine, address: int) -> None:
        self.line = line
        hit = due_breakpoint(self.breakpoints, line, self._condition)
        mode = self._mode
        if (
            hit is not None
            or self._interrupt
            or mode is Mode.STEP
            or (mode in (Mode.NEXT, Mode.OUT) and self.runner.cpu.sfr[_SP] <= self._next_sp)
        ):
            self._pause(Pause("line", line, hit))

    def close(self) -> None:
        """End the session; a paused worker unwinds."""
        self.ended = True
        if self._worker is not None and self._worker.is_alive():
            self._commands.put(None)
            self._worker.join(timeout=5)
        self.hooks.remove()

    # ------------------------------------------------------------------ reports

    def _source(self, line: SourceLine) -> str:
        lines = self.texts.get(line.file, [])
        return lines[line.line - 1].strip() if 0 < line.line <= len(lines) else ""

    def _position(self) -> str:
        time = f"{format_instant(self.now())}"
        if self.line is None:
            state = "before the first cycle" if not self.sim.started else "between cycles"
            return f"{state}, master time {time}, cycle {self.cycle}"
        where = describe(self.line, self.runner.cpu, self.line_map)
        return f"{where}, master time {time}, cycle {self.cycle}"

    def _report(self, pause: Pause) -> None:
        if pause.kind == "error":
            self.out(f"error: the simulation failed: {pause.text}")
        elif pause.kind == "end":
            self.out(f"end of the simulation at {format_instant(self.sim.end_ms)} "
                     f"({self.sim.result.checked} expectations checked, "
                     f"{len(self.sim.result.failures)} failed)")
        elif pause.kind == "time":
            self.out(f"master time {format_instant(self.now())} (cycle {self.cycle})")
        elif pause.kind == "fault":
            if pause.line is not None:
                self.out(f"{self._position()}")
                self.out(f"{pause.line.line:6} | {self._source(pause.line)}")
        elif pause.kind == "cycle":
            self.out(f"cycle {self.cycle} starts at {format_instant(self.now())}")
        else:
            assert pause.line is not None
            why = f"breakpoint {pause.breakpoint.number}, " if pause.breakpoint else ""
            self.out(f"{why}{self._position()}")
            self.out(f"{pause.line.line:6} | {self._source(pause.line)}")

    def _report_events(self) -> None:
        result = self.sim.result
        failures, stops = self._reported
        file = self.prepared.scenario.file
        for f in result.failures[failures:]:
            self.out(f"{file}:{f.line}: {f}")
        for s in result.stops[stops:]:
            self.out(s.reported)
        self._reported = (len(result.failures), len(result.stops))
