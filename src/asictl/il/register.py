"""The single-bit register through a module, and the STEP 5 habits it catches.

IL's register rules (il-semantics.md) differ from STEP 5's in ways that compile and run:
a logic string begins only at the start of a program, block or segment (``***``), not
after ``=``, ``S``, ``R`` or a jump; ``JC`` leaves the register as it was, so after a JC
that did not jump it is 0; ``L KT`` loads the constant register, not the accumulators. A
STEP 5 programmer's program then does something other than its author meant, without a
word from the master. This module follows the register along every path of a module's
[PROGRAM] statements and reports:

- E213: an instruction that reads the register where it is undefined on every path;
- W201: ``A``/``O`` after ``=``, ``S`` or ``R`` in the same segment (a new string in STEP 5);
- W205: ``A``/``AN``/``=`` where the register is always 0, after a JC (or BEC) that did
  not jump (STEP 5's JC starts a new string);
- W206: ``T`` right after ``L KT``/``L KC``/``L KP``, which store an older ACCU1;
- W207: a combining ``A``/``O`` that a jump reaches with the register undefined (STEP 5
  programmers expect it to load there);
- W208: a backward jump whose condition reads only inputs (or none): the inputs stay as
  they are during a cycle, so once it jumps the cycle never ends (a cycle time-out).
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from enum import Enum
from typing import assert_never

from asictl.codes import CheckCode
from asictl.diagnostics import Reporter
from asictl.il import ast
from asictl.il.ast import key


class _State(Enum):
    """What the register may hold when a statement starts, on one path."""

    UNDEFINED = "undefined"  # start of program, block or segment
    ZERO = "0"  # known 0: after a JC or BEC that did not jump
    DEFINED = "defined"


_U, _Z, _D = _State.UNDEFINED, _State.ZERO, _State.DEFINED
_KEEPS_ZERO = (ast.LogicOp.A, ast.LogicOp.AN)
_CONSTANT_REGISTER = (ast.OperandKind.KT, ast.OperandKind.KC, ast.OperandKind.KP)
_INPUTS = (ast.OperandKind.I, ast.OperandKind.I2)


def reads_register(statement: ast.Statement) -> bool:
    """Whether a statement reads the register (A/AN/O/ON only when not first checks)."""
    match statement:
        case ast.Jump(conditional=c) | ast.CallFB(conditional=c):
            return c
        case ast.BlockEnd(kind=kind):
            return kind is ast.EndKind.BEC
        case ast.Store() | ast.Not() | ast.Param() | ast.Count():
            return True
        case (ast.Logic() | ast.Load() | ast.Transfer() | ast.Arith() | ast.Compare()
              | ast.SegmentEnd() | ast.Asm() | ast.Label()):
            return False
        case _:
            assert_never(statement)


def _after_skipped(module: ast.Module, skipped: Sequence[int]) -> set[int]:
    """Indexes (into the flat statements) of statements with a skipped line just before
    them in their section: what that line did to the register is unknown."""
    found: set[int] = set()
    if not skipped:
        return found
    index = 0
    for section in module.sections_of(ast.ProgramSection):
        previous = section.span.line if section.span else 0
        for statement in section.statements:
            line = statement.span.line if statement.span else previous
            if bisect.bisect_right(skipped, previous) < bisect.bisect_left(skipped, line):
                found.add(index)
            previous = line
            index += 1
    return found


class _Module:
    """A module's [PROGRAM] statements as one list, with what the analyses share."""

    def __init__(self, module: ast.Module, skipped: Sequence[int]) -> None:
        sections = [list(s.statements) for s in module.sections_of(ast.ProgramSection)]
        self.flat: list[ast.Statement] = [s for section in sections for s in section]
        #: the first statement of each section: each section starts a new segment (3.4)
        self.starts: set[int] = set()
        index = 0
        for section in sections:
            self.starts.add(index)
            index += len(section)
        self.gaps = _after_skipped(module, skipped)
        self.labels = {key(s.name): i for i, s in enumerate(self.flat) if isinstance(s, ast.Label)}
        self.first_check: set[int] = set()
        #: the states each statement may start in (empty: no path reaches it)
        self.states: list[set[_State]] = [set() for _ in self.flat]
        #: (jump, target) for each jump that lands with the register undefined
        self.undefined_landings: list[tuple[int, int]] = []

    def lexical(self, report: Reporter) -> None:
        """First checks (a lexical rule: segment and section starts, ``***``) and W201."""
        first, stored = True, False
        for i, statement in enumerate(self.flat):
            if i in self.starts:
                first, stored = True, False
            if i in self.gaps:
                first, stored = False, False
            if isinstance(statement, ast.SegmentEnd):
                first, stored = True, False
            if isinstance(statement, ast.Logic):
                if first:
                    self.first_check.add(i)
                elif stored:
                    report.warning(
                        CheckCode.LOGIC_AFTER_STORE,
                        f"'{statement.op.value}' after '=', S or R continues the old logic "
                        "string; end the segment with *** to start a new one",
                        statement.span,
                    )
                first, stored = False, False
            elif isinstance(statement, ast.Compare):
                first, stored = False, False  # a comparison loads the register
            elif isinstance(statement, ast.Store):
                stored = True

    def flow(self) -> None:
        """Every state the register may start each statement in, along jumps."""
        flat, states = self.flat, self.states
        work: list[tuple[int, _State, int]] = [(0, _U, -1)] if flat else []
        while work:
            i, state, came_from = work.pop()
            if i >= len(flat):
                continue
            if i in self.gaps:
                state = _D
            if came_from >= 0 and state is _U:
                self.undefined_landings.append((came_from, i))
            if state in states[i]:
                continue
            states[i].add(state)
            for j, after, jumped in self._next(i, state):
                work.append((j, after if j not in self.starts or jumped else _U,
                             i if jumped else -1))

    def _next(self, i: int, state: _State) -> list[tuple[int, _State, bool]]:
        """Where statement ``i`` goes from ``state``, in which state, and by a jump."""
        statement = self.flat[i]
        after = state
        match statement:
            case ast.Logic(op=op):
                if i in self.first_check:
                    after = _D
                elif state is _Z and op not in _KEEPS_ZERO:
                    after = _D  # 0 or x is x
            case ast.Compare() | ast.Asm() | ast.CallFB():
                after = _D
            case ast.SegmentEnd():
                after = _U
            case ast.Not():
                after = _D if state is _Z else state
            case ast.Jump(conditional=conditional, label=label):
                target = self.labels.get(key(label))
                jumps = [] if target is None else [(target, state, True)]
                if not conditional:
                    return jumps
                if state is _Z:
                    jumps = []  # never taken
                return [*jumps, (i + 1, _Z if state is _D else state, False)]
            case ast.BlockEnd(kind=kind):
                if kind is not ast.EndKind.BEC:
                    return []
                return [(i + 1, _Z if state is _D else state, False)]
            case (ast.Store() | ast.Count() | ast.Param() | ast.Load() | ast.Transfer()
                  | ast.Arith() | ast.Label()):
                pass
            case _:
                assert_never(statement)
        return [(i + 1, after, False)]

    def reads(self, i: int) -> bool:
        statement = self.flat[i]
        return reads_register(statement) or (
            isinstance(statement, ast.Logic) and i not in self.first_check
        )


def check_register(module: ast.Module, report: Reporter, skipped: Sequence[int]) -> None:
    """E213, W201 and the STEP 5 traps W205-W208 of one module (see the module's text).

    A line skipped for a syntax error may have been an A or O: after one, the register
    counts as defined and the logic string as begun, so no error follows from the gap.
    """
    code = _Module(module, skipped)
    code.lexical(report)
    code.flow()
    for i, statement in enumerate(code.flat):
        states = code.states[i]
        if code.reads(i) and states == {_U}:
            report.error(
                CheckCode.UNDEFINED_REGISTER,
                f"'{_op_text(statement)}' reads the single-bit register, which is always "
                "undefined here (start of program, block or segment): begin with A, AN, O or ON",
                statement.span,
            )
    _always_zero(code, report)
    _transfer_after_constant(code, report)
    _landing_undefined(code, report)
    _endless_loops(code, report)


def _always_zero(code: _Module, report: Reporter) -> None:
    """W205, once per run: the first A/AN or '=' that only a JC's 'not jumped' reaches."""
    warned_run = -1
    for i, statement in enumerate(code.flat):
        combining = (isinstance(statement, ast.Logic) and statement.op in _KEEPS_ZERO
                     and i not in code.first_check)
        assigns = isinstance(statement, ast.Store) and statement.op is ast.StoreOp.ASSIGN
        if not (combining or assigns) or code.states[i] != {_Z}:
            continue
        run = _run_start(code, i)
        if run == warned_run:
            continue
        warned_run = run
        what = (f"'{_op_text(statement)}' is always 0" if combining
                else f"'{statement.to_source()}' always writes 0")
        before = code.flat[run - 1] if run > 0 else None
        why = ("the BEC before it did not end the cycle" if isinstance(before, ast.BlockEnd)
               else "the JC before it did not jump")
        report.warning(
            CheckCode.ALWAYS_ZERO,
            f"{what}: {why}, so the register is 0, and neither starts a new logic string "
            "(STEP 5's JC does); start one with ***",
            statement.span,
        )


def _run_start(code: _Module, i: int) -> int:
    """Where the run of statements that ``i`` belongs to began (after the last JC/BEC)."""
    while i > 0 and not isinstance(code.flat[i - 1], ast.Jump | ast.BlockEnd):
        i -= 1
    return i


def _transfer_after_constant(code: _Module, report: Reporter) -> None:
    """W206: ``L KT 500`` then ``T FY 10`` stores the older ACCU1, not the time."""
    flat = code.flat
    for i in range(1, len(flat)):
        before, statement = flat[i - 1], flat[i]
        if (isinstance(statement, ast.Transfer) and isinstance(before, ast.Load)
                and before.operand.kind in _CONSTANT_REGISTER and i not in code.starts):
            report.warning(
                CheckCode.TRANSFER_AFTER_CONSTANT,
                f"'{statement.to_source()}' right after '{before.to_source()}' stores ACCU1, "
                f"which L {before.operand.kind.value} leaves alone (it loads the constant "
                "register for S T, S C and PARAM): an older value is stored; load the "
                "number with L KB or L KW",
                statement.span,
            )


def _landing_undefined(code: _Module, report: Reporter) -> None:
    """W207: a combining A/O a jump reaches with the register undefined (on that path
    only: on every path it is E213)."""
    jumps_to: dict[int, list[int]] = {}
    for jump, target in code.undefined_landings:
        jumps_to.setdefault(target, []).append(jump)
    for target, jumps in sorted(jumps_to.items()):
        i = target
        while i < len(code.flat) and isinstance(code.flat[i], ast.Label):
            i += 1
        if i >= len(code.flat) or not isinstance(code.flat[i], ast.Logic):
            continue
        if i in code.first_check or code.states[i] == {_U}:
            continue
        statement = code.flat[i]
        places = [code.flat[j].span for j in sorted(set(jumps))]
        report.warning(
            CheckCode.LANDING_UNDEFINED,
            f"'{_op_text(statement)}' combines with the register, which is undefined on the "
            "path of the jump that lands here (it leaves a segment start; STEP 5 would load "
            "the operand here): put *** before the label, or jump from after a first check",
            statement.span,
            [(span, "the jump") for span in places if span is not None],
        )


def _endless_loops(code: _Module, report: Reporter) -> None:
    """W208: a backward jump that, once taken, is taken again every time."""
    flat = code.flat
    for j, statement in enumerate(flat):
        if not isinstance(statement, ast.Jump):
            continue
        start = code.labels.get(key(statement.label))
        if start is None or start > j or not code.states[j]:
            continue
        body = range(start, j + 1)
        if any(_leaves(code, k, body) for k in range(start, j)):
            continue
        if statement.conditional and not _reads_only_inputs(code, j, start):
            continue
        label = flat[start].span
        why = ("it jumps back every time" if not statement.conditional else
               "its condition reads only inputs, which stay as they are during a cycle")
        report.warning(
            CheckCode.ENDLESS_LOOP,
            f"'{statement.to_source()}' is a loop no cycle leaves once it jumps: {why}, so "
            "the cycle time-out stops the program; a program cannot wait for an input "
            "inside one cycle: jump forward and look again in the next cycle",
            statement.span,
            [(label, "the loop starts here")] if label is not None else [],
        )


def _leaves(code: _Module, k: int, body: range) -> bool:
    """Whether statement ``k`` of a loop's body may end the loop: a jump out of it, a
    block end, or a call whose block may do anything."""
    statement = code.flat[k]
    match statement:
        case ast.Jump(label=label):
            return code.labels.get(key(label), -1) not in body
        case ast.BlockEnd() | ast.CallFB() | ast.Asm():
            return True
        case (ast.Logic() | ast.Store() | ast.Not() | ast.Load() | ast.Transfer() | ast.Arith()
              | ast.Compare() | ast.Count() | ast.SegmentEnd() | ast.Param() | ast.Label()):
            return False
        case _:
            assert_never(statement)


def _reads_only_inputs(code: _Module, j: int, start: int) -> bool:
    """Whether the register at the jump ``j`` comes from a logic string inside the loop
    that reads nothing but inputs (I, I2)."""
    flat = code.flat
    for k in range(j - 1, start - 1, -1):
        statement = flat[k]
        match statement:
            case ast.Logic(operand=operand):
                if operand.kind not in _INPUTS:
                    return False
                if k in code.first_check:
                    return True
            case (ast.Not() | ast.Store() | ast.Load() | ast.Transfer() | ast.Arith()
                  | ast.Param() | ast.Count() | ast.Label()):
                pass  # N inverts an input's value; the others leave the register as it is
            case (ast.Compare() | ast.SegmentEnd() | ast.Asm() | ast.CallFB() | ast.Jump()
                  | ast.BlockEnd()):
                return False  # not the inputs alone, or not one path
            case _:
                assert_never(statement)
    return False  # the string began before the loop


def _op_text(statement: ast.Statement) -> str:
    return statement.to_source().split(" ")[0]
