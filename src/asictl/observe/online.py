"""Online values: every IL line of a running emulated board with what its latest cycle did.

This is STEP 7's "monitor block" for the emulated master: for each line with code, the
single-bit register, ACCU1, ACCU2 and the line's operand as the line left them in the
latest program cycle, or that the line did not run in it. The values come from the board
itself, not from a second simulation: ``latest_cycle`` installs the line hooks
(``observe.hooks``) for one program cycle, records its rows exactly as ``--trace-il`` does
(``ILTracer``), and removes the hooks again, so the board runs at full speed between
two requests. A real PC2's firmware reports nothing of the kind.

The master skips program cycles that would repeat the last one exactly; a request wakes
it (a host access, as the simulator's trace window does), so the recorded cycle really
runs, and it is the same cycle the skipped ones would have been.

The answer is JSON (it crosses the live board's socket as an emulated-only action):
``{"identity": HEX or null, "state": "running", "master_ms": T or null, "note": TEXT,
"lines": [{"file": NAME, "line": N, "ran": BOOL, "runs": N, "rlo": 0/1, "accu1": N,
"accu2": N, "constant": N, "operand": N or null}, ...]}`` (``constant``: the constant
register L KT, L KC and L KP load): one entry per line with code; the values are
null for a line that did not run, and a line that ran more than once (a loop, a block
called twice) shows its last run. ``CycleLines.from_json`` reads it back.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

from asictl.board.board import Pc2Board
from asictl.build import program_of_image
from asictl.errors import ExitCode, UserError
from asictl.image.eeprom import ImageError, ProgramImage
from asictl.observe.iltrace import ILTracer, LineRow, line_operands
from asictl.observe.operands import Operand
from asictl.observe.view import ProgramView, read_on_board, wake
from asictl.platform import pc2
from asictl.platform.master import CYCLE_TIMEOUT_MS
from asictl.runtime.line_map import SourceLine

JSON = Any

#: Why an image gives no per-line values.
NO_LINE_MAP = "the image has no line map (format version 1): no per-line values"
#: Master time a request lets pass at most for one program cycle to run: a cycle that
#: may last up to the time-out, after one that did.
WAIT_MS = 2.0 * CYCLE_TIMEOUT_MS + 10.0
#: The steps of that wait (an AS-i cycle lasts 300 us at the least).
STEP_MS = 0.25

#: The operands of the last image asked about (parsing its source takes a while; a board
#: runs one image for many requests).
_operands_of: list[tuple[ProgramImage, dict[SourceLine, Operand]]] = []


@dataclass(frozen=True)
class LineValues:
    """One IL line in the latest cycle; the values are None when it did not run."""

    line: SourceLine
    runs: int = 0
    rlo: int | None = None
    accu1: int | None = None
    accu2: int | None = None
    operand: int | None = None
    #: the constant register (L KT, L KC, L KP)
    constant: int | None = None

    @property
    def ran(self) -> bool:
        return self.runs > 0


@dataclass(frozen=True)
class CycleLines:
    """What ``latest_cycle`` answered, read back."""

    identity: str | None
    state: str
    #: the master time of the recorded cycle (None: no cycle was recorded)
    master_ms: float | None
    #: why no cycle was recorded, in words ("" when one was)
    note: str
    lines: dict[SourceLine, LineValues]

    @classmethod
    def from_json(cls, data: JSON) -> CycleLines:
        try:
            lines = {}
            for entry in data["lines"]:
                line = SourceLine(str(entry["file"]), int(entry["line"]))
                runs = int(entry["runs"])
                lines[line] = LineValues(line) if not runs else LineValues(
                    line, runs, int(entry["rlo"]), int(entry["accu1"]), int(entry["accu2"]),
                    None if entry["operand"] is None else int(entry["operand"]),
                    int(entry.get("constant", 0)),
                )
            master_ms = data["master_ms"]
            return cls(
                None if data["identity"] is None else str(data["identity"]),
                str(data["state"]), None if master_ms is None else float(master_ms),
                str(data["note"]), lines,
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise UserError(
                f"a malformed answer about the program's lines: {exc!r}", ExitCode.FAILED
            ) from None


def latest_cycle(board: Pc2Board) -> JSON:
    """Run the board until one program cycle has run under the line hooks (at most
    ``WAIT_MS`` of master time) and answer with its lines; see the module docstring."""
    image, runner = board.loaded_image, board.program
    state = board.control_state.name.lower()
    answer: dict[str, JSON] = {
        "identity": None if image is None else image.identity_hex, "state": state,
        "master_ms": None, "note": "", "lines": [],
    }
    if image is None or runner is None:
        answer["note"] = board.program_error or "no program is loaded"
        return answer
    line_map = image.line_map
    if not line_map:
        answer["note"] = NO_LINE_MAP
        return answer
    rows: list[LineRow] = []
    if board.control_state is not pc2.ControlState.RUNNING or board.in_reset:
        answer["note"] = "the program is not running"
    else:
        tracer = ILTracer(
            runner, line_map, texts={}, clock=lambda: board.now_ms,
            view=ProgramView(runner, functools.partial(read_on_board, board)),
            operands=_operands(image),
        )
        tracer.hooks.install()
        try:
            wake(board)
            waited = 0.0
            while not tracer.completed and waited < WAIT_MS and board.control_state is \
                    pc2.ControlState.RUNNING:
                board.advance(STEP_MS)
                waited += STEP_MS
        finally:
            tracer.hooks.remove()
        rows = [row for row in tracer.rows if tracer.completed and row.cycle == tracer.completed]
        if tracer.completed:
            answer["master_ms"] = rows[0].time_ms if rows else board.now_ms
        else:
            answer["note"] = (
                "the program stopped before its cycle ended"
                if board.control_state is not pc2.ControlState.RUNNING
                else f"no program cycle ended within {WAIT_MS:g} ms"
            )
        answer["state"] = board.control_state.name.lower()
    answer["lines"] = _entries(line_map.lines(), rows)
    return answer


def _entries(lines: list[SourceLine], rows: list[LineRow]) -> list[dict[str, JSON]]:
    last: dict[SourceLine, LineRow] = {}
    runs: dict[SourceLine, int] = {}
    for done in rows:
        last[done.line] = done
        runs[done.line] = runs.get(done.line, 0) + 1
    entries = []
    for line in lines:
        row = last.get(line)
        entry: dict[str, JSON] = {
            "file": line.file, "line": line.line, "ran": row is not None,
            "runs": runs.get(line, 0), "rlo": None, "accu1": None, "accu2": None,
            "constant": None, "operand": None,
        }
        if row is not None:
            entry.update(rlo=row.rlo, accu1=row.accu1, accu2=row.accu2,
                         constant=row.constant, operand=row.operand)
        entries.append(entry)
    return entries


def _operands(image: ProgramImage) -> dict[SourceLine, Operand]:
    """The operand of each line, from the source the image carries (none without)."""
    if _operands_of and _operands_of[0][0] is image:
        return _operands_of[0][1]
    try:
        operands = line_operands(program_of_image(image))
    except ImageError:  # the source is damaged: values without operands
        operands = {}
    _operands_of[:] = [(image, operands)]
    return operands

