"""The symbolic program cycle: the reference interpreter's rules over z3 terms.

``il/oracle.py`` runs a program cycle on concrete bytes; this module runs the same cycle,
statement by statement and in the same order, on z3 terms: bytes, the accumulators, the
constant register, timers and counters are bit-vectors, the single-bit register is a
Bool. The result is the transition of one cycle: every memory cell after the cycle as a
term over the cells before it and the cycle's inputs (the slaves' data, the flags a host
writes, what firmware blocks answer). The prover unrolls it (``prove.engine``); a test
runs it on concrete values beside the simulator and the interpreter.

Jumps split the paths of a cycle: each path carries the condition under which it is
taken, and paths that meet at a label merge into one state (``If(taken, a, b)`` per
cell), so a cycle's terms grow with its code, not with its number of paths. Paths are
followed in statement order, so that every path reaching a label has arrived before the
label is run. A backward jump is followed at most ``unroll`` times; a path that would
jump once more is a cycle the model does not cover, and the prover reports it rather than
decide anything about it (``Cycle.overrun``).

What the model leaves open, so that what it proves holds however it is resolved: the
answers of firmware blocks (every PSeg byte after a call), and the phase of the master's
10 ms clock (``Cycle.tick`` holds the time from a cycle's start to the next tick; its
first value is free within one tick period). Between two cycle starts P apart the clock
ticks P // 10 ms times, or once more when the next tick comes within P % 10 ms: exact as
long as the time to the next tick is 1 us to 10 ms, which it always is after a cycle
(the first cycle's value is set by the caller, as the phase).
"""

from __future__ import annotations

import heapq
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import assert_never

import z3

from asictl.diagnostics import Span
from asictl.il import ast
from asictl.il.ast import key
from asictl.il.language import COUNTER_FLAG_BASE, MAPPED_COUNTERS, PARAM_FLAG
from asictl.il.language import TC_MAX_VALUE as TC_MAX
from asictl.il.loader import Program
from asictl.il.oracle import Scope, scope_of
from asictl.platform.master import TICK_US, flag_keeps
from asictl.readers.units import timer_ticks

K = ast.OperandKind
#: A memory cell: ("I", byte), ("I2", byte), ("Q", byte), ("F", byte), ("P", byte),
#: ("V", name, byte), ("T", n), ("C", n), ("A1",), ("A2",), ("K",) (the constant
#: register) and ("R",) (microseconds from the cycle's start to the next 10 ms tick, 1 to
#: 10,000).
Key = tuple[str | int, ...]
ACCU1: Key = ("A1",)
ACCU2: Key = ("A2",)
CONSTANT: Key = ("K",)
TICK: Key = ("R",)
#: How often a backward jump is followed in one cycle unless the caller says otherwise.
UNROLL = 8


class TimeLimit(Exception):
    """The deadline passed while the model was being built: a program of many loops
    can take longer to build than to decide, and the command's limit counts it too."""


def check_deadline(deadline: float | None) -> None:
    """Raise ``TimeLimit`` once ``deadline`` (time.monotonic) has passed."""
    if deadline is not None and time.monotonic() > deadline:
        raise TimeLimit


class Unmodelled(Exception):
    """A construct the symbolic cycle cannot run exactly (ASM code, a program without
    source): refused rather than modelled wrongly."""

    def __init__(self, message: str, span: Span | None) -> None:
        super().__init__(message)
        self.span = span


#: The first part of a cell of one side of two programs compared (``product``).
SIDES = ("a", "b")


def width(cell: Key) -> int:
    kind = cell[1] if cell[0] in SIDES else cell[0]
    return 16 if kind in ("T", "C", "A1", "A2", "K", "R") else 8


def cell_name(cell: Key) -> str:
    return ".".join(str(part) for part in cell)


@dataclass
class _State:
    """The cells one path changed so far (the rest still hold their value before the
    cycle) and the single-bit register."""

    values: dict[Key, z3.BitVecRef]
    rlo: z3.BoolRef

    def copy(self) -> _State:
        return _State(dict(self.values), self.rlo)


@dataclass(frozen=True)
class Loop:
    """A backward jump, followed at most ``bound`` times per cycle."""

    line: int
    bound: int


@dataclass
class Cycle:
    """One program cycle as terms: ``post[cell]`` over ``pre`` (the cells before the
    cycle, one variable each) and ``inputs`` (fresh every cycle)."""

    pre: dict[Key, z3.BitVecRef]
    post: dict[Key, z3.BitVecRef]
    #: input name -> its variable: slave data ("in.A", 4 bits), host-written flag bytes
    #: ("host.N"), firmware answers ("fw.K.N")
    inputs: dict[str, z3.BitVecRef]
    #: the bits of each host-written flag byte
    host_masks: dict[int, int]
    #: true when the cycle would follow a backward jump more often than its bound
    overrun: z3.BoolRef
    loops: list[Loop]
    cycle_us: int
    timers: tuple[int, ...]
    #: the slaves on the bus (their inputs are free)
    slaves: tuple[int, ...]
    #: each timer's cell (``("T", n)``, or under its side in ``product``) -> true when
    #: the cycle stores into it (``S``, ``R``, ``T T n``, whether the store changes it or
    #: not): a timer not stored into only counts down
    stored: dict[Key, z3.BoolRef] = field(default_factory=dict)

    @property
    def cells(self) -> list[Key]:
        return sorted(self.post, key=cell_name)

    def initial(self) -> dict[Key, z3.BitVecRef]:
        """The cells after a reset (all 0; the tick phase is the caller's to set after
        the first cycle)."""
        return {cell: z3.BitVecVal(0, width(cell)) for cell in self.post}


def _stored(timer: int) -> Key:
    """The mark (not a cell of the master) that a cycle stored into ``timer``: set while
    the cycle is built, taken out of the state at its end (``Cycle.stored``)."""
    return ("stored", timer)


def _bv(value: int, bits: int) -> z3.BitVecRef:
    return z3.BitVecVal(value, bits)


def _ite(condition: z3.BoolRef, a: z3.BitVecRef, b: z3.BitVecRef) -> z3.BitVecRef:
    if a.eq(b):
        return a
    result: z3.BitVecRef = z3.If(condition, a, b)
    return result


def _bit(byte: z3.BitVecRef, bit: int) -> z3.BoolRef:
    result: z3.BoolRef = z3.Extract(bit, bit, byte) == 1
    return result


def _with_bit(byte: z3.BitVecRef, bit: int, value: z3.BoolRef) -> z3.BitVecRef:
    mask = 1 << bit
    return _ite(value, byte | mask, byte & (~mask & 0xFF))


def _byte16(value: z3.BitVecRef) -> z3.BitVecRef:
    result: z3.BitVecRef = z3.ZeroExt(8, value)
    return result


def _low(value: z3.BitVecRef) -> z3.BitVecRef:
    result: z3.BitVecRef = z3.Extract(7, 0, value)
    return result


def _clamp(value: z3.BitVecRef) -> z3.BitVecRef:
    """min(value, 4095), unsigned, as timers and counters take a word."""
    return _ite(z3.UGT(value, TC_MAX), _bv(TC_MAX, 16), value)


_COMPARE: dict[ast.CompareOp, Callable[[z3.BitVecRef, z3.BitVecRef], z3.BoolRef]] = {
    ast.CompareOp.EQ: lambda a, b: a == b,
    ast.CompareOp.NE: lambda a, b: a != b,
    ast.CompareOp.GT: z3.UGT,
    ast.CompareOp.GE: z3.UGE,
    ast.CompareOp.LT: z3.ULT,
    ast.CompareOp.LE: z3.ULE,
}


def image_cell(kind: ast.OperandKind, address: int) -> Key:
    """The byte of a data image that holds slave ``address`` (two slaves a byte)."""
    return ({K.I: "I", K.I2: "I2", K.Q: "Q", K.IB: "I", K.I2B: "I2", K.QB: "Q"}[kind],
            address >> 1)


def timers_of(program: Program) -> tuple[int, ...]:
    """The timers the program uses: the ones the 10 ms clock counts down."""
    return tuple(sorted({
        operand.address
        for module in program.modules()
        for section in module.sections
        for node in ast.nodes(section)
        if isinstance(node, ast.Statement | ast.GatingLine)
        for operand, _ in ast.operands(node)
        if operand.kind is K.T
    }))


def counter_high_bytes(program: Program) -> tuple[int, ...]:
    """The flag bytes whose bits 4-7 the master keeps at 0: the high bytes of the mapped
    counters (``map_counters``), whatever the program or the host writes there."""
    if not program.options.map_counters:
        return ()
    return tuple(COUNTER_FLAG_BASE + 2 * n + 1 for n in range(MAPPED_COUNTERS))


def refuse_unmodelled(program: Program) -> None:
    """Raise ``Unmodelled`` for the first construct the symbolic cycle cannot run."""
    for module in program.modules():
        for section in module.sections:
            if isinstance(section, ast.AssemblySection):
                raise Unmodelled("an [ASSEMBLY] section (8051 code) cannot be modelled",
                                 section.span)
            if isinstance(section, ast.RawSection):
                raise Unmodelled("a [RAW] image (compiled code without its source) cannot "
                                 "be modelled", section.span)
            for node in ast.nodes(section):
                if isinstance(node, ast.Asm):
                    raise Unmodelled(f"the ASM line '{node.text}' (8051 code) cannot be "
                                     "modelled", node.span)


class _Builder:
    """Runs the program once over symbolic cells, as ``Interpreter._run`` does."""

    def __init__(self, program: Program, *, map_counters: bool, unroll: int,
                 fresh: Callable[[str, int], z3.BitVecRef], deadline: float | None) -> None:
        self.program = program
        self.deadline = deadline
        self.map_counters = map_counters
        self.unroll = unroll
        self.fresh = fresh
        self.main = scope_of(program.main)
        self.blocks = {name: scope_of(module) for name, module in program.blocks.items()}
        self.pre: dict[Key, z3.BitVecRef] = {}
        self.inputs: dict[str, z3.BitVecRef] = {}
        self.overrun: list[z3.BoolRef] = []
        self.loops: dict[int, Loop] = {}
        self._calls = 0

    # ------------------------------------------------------------------ cells

    def var(self, cell: Key) -> z3.BitVecRef:
        found = self.pre.get(cell)
        if found is None:
            found = self.pre[cell] = self.fresh(cell_name(cell), width(cell))
        return found

    def input(self, name: str, bits: int) -> z3.BitVecRef:
        variable = self.inputs[name] = self.fresh(name, bits)
        return variable

    def get(self, state: _State, cell: Key) -> z3.BitVecRef:
        value = state.values.get(cell)
        if value is None:
            value = state.values[cell] = self.var(cell)
        return value

    def merge(self, entries: list[tuple[z3.BoolRef, _State]]) -> tuple[z3.BoolRef, _State]:
        guard, state = entries[0]
        for other_guard, other in entries[1:]:
            cells = state.values.keys() | other.values.keys()
            merged = _State(
                {c: _ite(guard, self.get(state, c), self.get(other, c)) for c in cells},
                state.rlo if state.rlo.eq(other.rlo) else z3.If(guard, state.rlo, other.rlo),
            )
            guard, state = z3.Or(guard, other_guard), merged
        return guard, state

    # ------------------------------------------------------------------ control flow

    def run(self, scope: Scope, guard: z3.BoolRef, state: _State) -> tuple[z3.BoolRef, _State]:
        """Every path through ``scope`` from ``state``, merged at its end (the returns of a
        block, the end of the cycle)."""
        statements = scope.statements
        pending: dict[int, list[tuple[z3.BoolRef, _State]]] = {0: [(guard, state)]}
        queue = [0]
        ended: list[tuple[z3.BoolRef, _State]] = []
        taken: dict[int, int] = {}

        def arrive(pc: int, entry: tuple[z3.BoolRef, _State]) -> None:
            if pc not in pending:
                pending[pc] = []
                heapq.heappush(queue, pc)
            pending[pc].append(entry)

        while queue:
            check_deadline(self.deadline)
            pc = heapq.heappop(queue)
            g, s = self.merge(pending.pop(pc))
            while True:
                if pc == len(statements):
                    ended.append((g, s))
                    break
                if pc in pending:  # other paths meet this one here
                    pending[pc].append((g, s))
                    break
                statement = statements[pc]
                pc += 1
                if isinstance(statement, ast.Jump):
                    target = scope.labels[key(statement.label)]
                    conditional = statement.conditional
                    go = z3.And(g, s.rlo) if conditional else g
                    if target < pc:
                        count = taken[pc] = taken.get(pc, 0) + 1
                        line = statement.span.line if statement.span else 0
                        self.loops[line] = Loop(line, self.unroll)
                        if count > self.unroll:
                            self.overrun.append(go)
                        else:
                            arrive(target, (go, s.copy()))
                    else:
                        arrive(target, (go, s.copy()))
                    if not conditional:
                        break
                    g = z3.And(g, z3.Not(s.rlo))
                elif isinstance(statement, ast.BlockEnd):
                    if statement.kind is not ast.EndKind.BEC:
                        ended.append((g, s))
                        break
                    ended.append((z3.And(g, s.rlo), s.copy()))
                    g = z3.And(g, z3.Not(s.rlo))
                elif isinstance(statement, ast.CallFB):
                    if statement.conditional:
                        called = self.call(statement.name, z3.And(g, s.rlo), s.copy())
                        s = self.merge([called, (z3.And(g, z3.Not(s.rlo)), s)])[1]
                    else:
                        s = self.call(statement.name, g, s)[1]
                else:
                    self.step(statement, scope, pc - 1, s)
        if not ended:  # every path overran
            return z3.BoolVal(False), state
        return self.merge(ended)

    def call(self, name: str, guard: z3.BoolRef, state: _State) -> tuple[z3.BoolRef, _State]:
        block = self.blocks.get(key(name))
        if block is not None:
            return self.run(block, guard, state)
        self.firmware(state)
        return guard, state

    def firmware(self, state: _State) -> None:
        """A firmware block: its answer in PSeg is any answer."""
        self._calls += 1
        for n in range(16):
            state.values[("P", n)] = self.input(f"fw.{self._calls}.{n}", 8)

    # ------------------------------------------------------------------ statements

    def step(self, statement: ast.Statement | ast.GatingLine, scope: Scope, index: int,
             s: _State) -> None:
        match statement:
            case ast.Logic(op=op, operand=operand):
                value = self.read_bit(s, operand)
                if op in (ast.LogicOp.AN, ast.LogicOp.ON):
                    value = z3.Not(value)
                if index in scope.first_check:
                    s.rlo = value
                elif op in (ast.LogicOp.A, ast.LogicOp.AN):
                    s.rlo = z3.And(s.rlo, value)
                else:
                    s.rlo = z3.Or(s.rlo, value)
            case ast.Store(op=op, operand=operand):
                self.store(s, op, operand)
            case ast.Not():
                s.rlo = z3.Not(s.rlo)
            case ast.Load(operand=operand):
                self.load(s, operand)
            case ast.Transfer(operand=operand):
                self.transfer(s, operand)
            case ast.Arith(op=op):
                a2, a1 = _low(self.get(s, ACCU2)), _low(self.get(s, ACCU1))
                s.values[ACCU1] = _byte16(a2 + a1 if op is ast.ArithOp.ADD else a2 - a1)
            case ast.Compare(op=op):
                s.rlo = _COMPARE[op](_low(self.get(s, ACCU2)), _low(self.get(s, ACCU1)))
            case ast.Count(op=op, counter=counter):
                self.count(s, op, counter.address)
            case ast.SegmentEnd() | ast.Label():
                pass
            case ast.Param():
                self.param(s)
            case ast.GatingLine():
                self.gate(s, statement)
            case ast.Asm():
                raise Unmodelled(f"the ASM line '{statement.text}' cannot be modelled",
                                 statement.span)
            case ast.Jump() | ast.BlockEnd() | ast.CallFB():
                raise AssertionError("control flow is run by run()")
            case _:
                assert_never(statement)

    def param(self, s: _State) -> None:
        """PARAM is SendPrm with the KP register; its answer is any answer."""
        before = s.copy()
        constant = self.get(s, CONSTANT)
        s.values[("P", 0)] = _low(z3.LShR(constant, 4) & 0x1F)
        s.values[("P", 1)] = _low(constant & 0x0F)
        self.firmware(s)
        ok = self.get(s, ("P", 0)) == 0
        answer = _ite(ok, self.get(s, ("P", 1)) & 0x0F, _bv(0, 8))
        flag = self.get(s, ("F", PARAM_FLAG))
        s.values[("F", PARAM_FLAG)] = (flag & 0x70) | answer | _ite(ok, _bv(0x80, 8), _bv(0, 8))
        rlo = s.rlo
        for cell in s.values.keys() | before.values.keys():
            s.values[cell] = _ite(rlo, self.get(s, cell), self.get(before, cell))

    def gate(self, s: _State, line: ast.GatingLine) -> None:
        result: z3.BoolRef = z3.BoolVal(False)
        for term in line.terms:
            value = self.read_bit(s, term.operand)
            if term.negated:
                value = z3.Not(value)
            if term.op is ast.GatingOp.AND:
                result = z3.And(result, value)
            elif term.op is ast.GatingOp.OR:
                result = z3.Or(result, value)
            else:
                result = value
        s.rlo = result
        self.store(s, ast.StoreOp.ASSIGN, line.target)

    # ------------------------------------------------------------------ operands

    def byte_cell(self, operand: ast.Operand) -> Key:
        n = operand.address
        match operand.kind:
            case K.IB | K.I2B | K.QB:
                return image_cell(operand.kind, n)
            case K.FY:
                return ("F", n)
            case K.PSEG:
                return ("P", n)
            case K.VAR:
                return ("V", key(operand.name), n)
            case (K.I | K.I2 | K.Q | K.F | K.FW | K.T | K.C | K.KT | K.KC | K.KB | K.KW
                  | K.KP):
                raise AssertionError(f"{operand} is no byte operand")
            case _:
                assert_never(operand.kind)

    def bit_place(self, operand: ast.Operand) -> tuple[Key, int]:
        """The byte and bit of a bit operand kept in a byte."""
        address, bit = operand.address, operand.bit
        match operand.kind:
            case K.F:
                return ("F", address), bit
            case K.I | K.I2 | K.Q:
                return image_cell(operand.kind, address), (address & 1) * 4 + bit
            case K.VAR:
                return ("V", key(operand.name), address), bit
            case (K.T | K.C | K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.FW | K.KT | K.KC | K.KB
                  | K.KW | K.KP):
                raise AssertionError(f"{operand} is not kept in a byte")
            case _:
                assert_never(operand.kind)

    def read_bit(self, s: _State, operand: ast.Operand) -> z3.BoolRef:
        if operand.kind is K.T:
            result: z3.BoolRef = self.get(s, ("T", operand.address)) != 0
            return result
        if operand.kind is K.C:
            counted: z3.BoolRef = self.counter(s, operand.address) != 0
            return counted
        cell, bit = self.bit_place(operand)
        return _bit(self.get(s, cell), bit)

    def store(self, s: _State, op: ast.StoreOp, operand: ast.Operand) -> None:
        rlo = s.rlo
        if operand.kind is K.T:
            cell = ("T", operand.address)
            value = _clamp(self.get(s, CONSTANT)) if op is ast.StoreOp.SET else _bv(0, 16)
            s.values[cell] = _ite(rlo, value, self.get(s, cell))
            mark = _stored(operand.address)
            s.values[mark] = _ite(rlo, _bv(1, 8), s.values[mark])
            return
        if operand.kind is K.C:
            value = _clamp(self.get(s, CONSTANT)) if op is ast.StoreOp.SET else _bv(0, 16)
            self.set_counter(s, operand.address, value, rlo)
            return
        place, bit = self.bit_place(operand)
        byte = self.get(s, place)
        if op is ast.StoreOp.ASSIGN:
            self.put(s, place, _with_bit(byte, bit, rlo))
        else:
            self.put(s, place, _ite(rlo, _with_bit(byte, bit, z3.BoolVal(op is ast.StoreOp.SET)),
                                    byte))

    def put(self, s: _State, cell: Key, value: z3.BitVecRef) -> None:
        """Write a byte cell; a flag byte keeps only the bits it keeps (``flag_keeps``)."""
        if cell[0] == "F" and isinstance(cell[1], int):
            keeps = flag_keeps(cell[1], self.map_counters)
            if keeps != 0xFF:
                value = value & keeps
        s.values[cell] = value

    def load(self, s: _State, operand: ast.Operand) -> None:
        kind = operand.kind  # KT, KC and KP load the constant register, the rest ACCU1
        if kind is K.KT:
            s.values[CONSTANT] = _bv(timer_ticks(operand.address), 16)
        elif kind is K.KC:
            s.values[CONSTANT] = _bv(operand.address, 16)
        elif kind is K.KP:
            s.values[CONSTANT] = _bv(operand.address << 4 | operand.bit, 16)
        else:
            word = self.read_word(s, operand)
            s.values[ACCU2] = self.get(s, ACCU1)
            s.values[ACCU1] = word

    def read_word(self, s: _State, operand: ast.Operand) -> z3.BitVecRef:
        n = operand.address
        match operand.kind:
            case K.KB | K.KW:
                return _bv(n, 16)
            case K.FW:
                word: z3.BitVecRef = z3.Concat(self.get(s, ("F", n)), self.get(s, ("F", n + 1)))
                return word
            case K.T:
                return self.get(s, ("T", n))
            case K.C:
                return self.counter(s, n)
            case K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.VAR:
                return _byte16(self.get(s, self.byte_cell(operand)))
            case K.I | K.I2 | K.Q | K.F | K.KT | K.KC | K.KP:
                raise AssertionError(f"L {operand} loads no word")
            case _:
                assert_never(operand.kind)

    def transfer(self, s: _State, operand: ast.Operand) -> None:
        value = self.get(s, ACCU1)
        n = operand.address
        match operand.kind:
            case K.FW:
                self.put(s, ("F", n), z3.Extract(15, 8, value))
                self.put(s, ("F", n + 1), _low(value))
            case K.T:
                s.values[("T", n)] = _clamp(value)
                s.values[_stored(n)] = _bv(1, 8)
            case K.C:
                self.set_counter(s, n, _clamp(value))
            case K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.VAR:
                self.put(s, self.byte_cell(operand), _low(value))
            case K.I | K.I2 | K.Q | K.F | K.KT | K.KC | K.KB | K.KW | K.KP:
                raise AssertionError(f"T {operand} writes no word")
            case _:
                assert_never(operand.kind)

    # ------------------------------------------------------------------ counters

    def mapped(self, n: int) -> bool:
        return self.map_counters and n < MAPPED_COUNTERS

    def counter(self, s: _State, n: int) -> z3.BitVecRef:
        if self.mapped(n):
            low = self.get(s, ("F", COUNTER_FLAG_BASE + 2 * n))
            high = self.get(s, ("F", COUNTER_FLAG_BASE + 2 * n + 1))
            value: z3.BitVecRef = z3.Concat(_bv(0, 4), z3.Extract(3, 0, high), low)
            return value
        return self.get(s, ("C", n))

    def set_counter(self, s: _State, n: int, value: z3.BitVecRef,
                    when: z3.BoolRef | None = None) -> None:
        """Counter n := value (when ``when`` holds: a mapped counter's flags are left alone
        otherwise, their upper bits too)."""
        if self.mapped(n):
            low: Key = ("F", COUNTER_FLAG_BASE + 2 * n)
            high: Key = ("F", COUNTER_FLAG_BASE + 2 * n + 1)
            cells: tuple[tuple[Key, z3.BitVecRef], ...] = (
                (low, _low(value)), (high, z3.Extract(15, 8, value)))
        else:
            cells = ((("C", n), value),)
        for cell, bits in cells:
            s.values[cell] = bits if when is None else _ite(when, bits, self.get(s, cell))

    def count(self, s: _State, op: ast.CountOp, n: int) -> None:
        rlo = s.rlo
        old = self.counter(s, n)
        up = _ite(z3.UGE(old, TC_MAX), _bv(TC_MAX, 16), old + 1)
        down = _ite(old == 0, old, old - 1)
        if op is ast.CountOp.STP:
            self.set_counter(s, n, _ite(rlo, up, down))
        else:
            self.set_counter(s, n, up if op is ast.CountOp.CU else down, rlo)


def host_masks(flags: Iterable[ast.Operand]) -> dict[int, int]:
    """The bits of each flag byte a host writes (``; asictl: host F 10.0, FY 11, FW 12``)."""
    masks: dict[int, int] = {}
    for flag in flags:
        if flag.kind is K.F:
            masks[flag.address] = masks.get(flag.address, 0) | 1 << flag.bit
        else:
            for n in ast.flag_bytes(flag.kind, flag.address):
                masks[n] = 0xFF
    return masks


def build_cycle(
    program: Program,
    *,
    slaves: Iterable[int],
    cycle_us: int,
    host_flags: Iterable[ast.Operand] = (),
    watch: Iterable[Key] = (),
    unroll: int = UNROLL,
    prefix: str = "",
    deadline: float | None = None,
) -> Cycle:
    """The transition of one program cycle of ``program`` on a bus with ``slaves``, with
    program cycles ``cycle_us`` apart; ``watch`` are cells a caller reads after the cycle
    (a property's operands) besides those the program touches. ``prefix`` names the
    variables (two programs side by side need two sets). Past ``deadline``
    (time.monotonic) the building stops with ``TimeLimit``."""
    refuse_unmodelled(program)

    def fresh(name: str, bits: int) -> z3.BitVecRef:
        return z3.BitVec(prefix + name, bits)

    builder = _Builder(program, map_counters=program.options.map_counters, unroll=unroll,
                       fresh=fresh, deadline=deadline)
    on_bus = tuple(sorted(set(slaves)))
    timers = timers_of(program)
    start = _State({}, z3.BoolVal(False))
    values = start.values
    if timers:  # the ticks of the 10 ms clock since the previous cycle started
        whole, rest = divmod(cycle_us, TICK_US)
        until = builder.var(TICK)  # in 1..10 ms: a tick at until, until + 10 ms, ...
        extra = z3.ULE(until, rest)
        values[TICK] = z3.If(extra, until + (TICK_US - rest), until - rest)
        elapsed = z3.If(extra, _bv(whole + 1, 16), _bv(whole, 16))
        for n in timers:
            remaining = builder.var(("T", n))
            values[("T", n)] = z3.If(z3.UGT(remaining, elapsed), remaining - elapsed, 0)
            values[_stored(n)] = _bv(0, 8)
    for byte in range(16):  # I2 := I, I := the slaves' data
        nibbles = [builder.input(f"in.{a}", 4) if a in on_bus else _bv(0, 4)
                   for a in (2 * byte + 1, 2 * byte)]
        if any(not z3.is_bv_value(n) for n in nibbles):
            values[("I2", byte)] = builder.var(("I", byte))
            values[("I", byte)] = z3.Concat(*nibbles)
    masks = host_masks(host_flags)
    mapped = counter_high_bytes(program)
    for n, mask in sorted(masks.items()):
        written = builder.input(f"host.{n}", 8)
        if n in mapped:  # the board keeps what the host writes there within 0..15
            written = written & 0x0F
        values[("F", n)] = (builder.var(("F", n)) & (~mask & 0xFF)) | (written & mask)
    _, end = builder.run(builder.main, z3.BoolVal(True), start)
    for n in mapped:  # and what the program left there, after every cycle
        if ("F", n) in end.values:
            end.values[("F", n)] = end.values[("F", n)] & 0x0F
    stored: dict[Key, z3.BoolRef] = {
        ("T", n): z3.simplify(end.values.pop(_stored(n)) != 0) for n in timers}
    for cell in watch:
        builder.get(end, cell)
    for cell in list(builder.pre):
        builder.get(end, cell)
    post = {}
    for cell, value in end.values.items():
        check_deadline(deadline)
        post[cell] = z3.simplify(value)
    for cell in post:
        builder.var(cell)
    overrun = z3.simplify(z3.Or(*builder.overrun)) if builder.overrun else z3.BoolVal(False)
    return Cycle(builder.pre, post, builder.inputs, masks, overrun,
                 sorted(builder.loops.values(), key=lambda loop: loop.line), cycle_us, timers,
                 on_bus, stored)


# ---------------------------------------------------------------------- reading cells


def operand_cells(operand: ast.Operand, map_counters: bool) -> list[Key]:
    """The cells an operand as the tools name it (``observe.operands``) reads."""
    kind, n = operand.kind, operand.address
    if kind is K.T:
        return [("T", n)]
    if kind is K.C:
        if map_counters and n < MAPPED_COUNTERS:
            return [("F", COUNTER_FLAG_BASE + 2 * n), ("F", COUNTER_FLAG_BASE + 2 * n + 1)]
        return [("C", n)]
    if kind in (K.I, K.I2, K.Q, K.IB, K.I2B, K.QB):
        return [image_cell(kind, n)]
    if kind in (K.F, K.FY):
        return [("F", n)]
    if kind is K.PSEG:
        return [("P", n)]
    if kind is K.VAR:
        return [("V", key(operand.name), n)]
    return []


def operand_value(operand: ast.Operand, read: Callable[[Key], z3.BitVecRef],
                  map_counters: bool) -> z3.BitVecRef:
    """An operand's value (32 bits) as a scenario's ``expect`` reads it: a bit 0/1, a
    slave's four data bits, a byte, ``CV n`` (the count), ``TV n`` (milliseconds left)."""
    kind, n = operand.kind, operand.address
    if kind is K.T:
        ticks = z3.ZeroExt(16, read(("T", n)))
        return ticks * 10 if operand.width is ast.Width.WORD else z3.If(ticks != 0, _one(), _zero())
    if kind is K.C:
        if map_counters and n < MAPPED_COUNTERS:
            low = read(("F", COUNTER_FLAG_BASE + 2 * n))
            high = read(("F", COUNTER_FLAG_BASE + 2 * n + 1))
            count = z3.Concat(_bv(0, 20), z3.Extract(3, 0, high), low)
        else:
            count = z3.ZeroExt(16, read(("C", n)))
        return count if operand.width is ast.Width.WORD else z3.If(count != 0, _one(), _zero())
    cell = operand_cells(operand, map_counters)[0]
    byte = read(cell)
    if operand.width is ast.Width.NIBBLE:
        shift = (n & 1) * 4
        return z3.ZeroExt(28, z3.Extract(shift + 3, shift, byte))
    if operand.width is ast.Width.BIT:
        bit = (n & 1) * 4 + operand.bit if kind in (K.I, K.I2, K.Q) else operand.bit
        return z3.ZeroExt(31, z3.Extract(bit, bit, byte))
    return z3.ZeroExt(24, byte)


def _one() -> z3.BitVecRef:
    return _bv(1, 32)


def _zero() -> z3.BitVecRef:
    return _bv(0, 32)


def product(first: Cycle, second: Cycle) -> Cycle:
    """Two programs on one master, side by side: the cells of each under its side
    (``("a", "Q", 1)``, ``("b", "Q", 1)``), the inputs shared (the same slaves, the same
    host, the same firmware answers call for call) and one 10 ms clock. The two cycles
    must have been built with different ``prefix`` es."""
    shared = dict(first.inputs)
    pairs = [(var, shared.setdefault(name, var)) for name, var in second.inputs.items()]
    clock = first.pre.get(TICK, second.pre.get(TICK))
    if clock is not None and TICK in second.pre:
        pairs.append((second.pre[TICK], clock))

    def moved(term: z3.ExprRef) -> z3.ExprRef:
        return z3.substitute(term, *pairs) if pairs else term

    pre: dict[Key, z3.BitVecRef] = {}
    post: dict[Key, z3.BitVecRef] = {}
    stored: dict[Key, z3.BoolRef] = {}
    for side, cycle in zip(SIDES, (first, second), strict=True):
        for cell, mark in cycle.stored.items():
            stored[(side, *cell)] = moved(mark) if side == "b" else mark
        for cell, var in cycle.pre.items():
            if cell == TICK:
                assert clock is not None
                pre[TICK] = clock
            else:
                pre[(side, *cell)] = var
        for cell, term in cycle.post.items():
            post[TICK if cell == TICK else (side, *cell)] = moved(term) if side == "b" else term
    masks = dict(first.host_masks)
    for n, mask in second.host_masks.items():
        masks[n] = masks.get(n, 0) | mask
    return Cycle(pre, post, shared, masks, z3.Or(first.overrun, moved(second.overrun)),
                 [*first.loops, *second.loops], first.cycle_us, (),
                 tuple(sorted({*first.slaves, *second.slaves})), stored)
