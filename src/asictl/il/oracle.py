"""The reference interpreter: IL semantics executed directly on the AST.

This is the semantic oracle. It is written from the language reference
(``docs/language.md``) alone and shares no code with the code generator, so that
running a program both ways and comparing every output, flag, timer and counter after
every cycle tests the compiler against an independent reading of the rules.
It is not built for speed; the emulated master runs the compiled 8051 code.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import assert_never

from asictl.il import ast
from asictl.il.ast import key
from asictl.il.language import COUNTER_FLAG_BASE, MAPPED_COUNTERS, PARAM_FLAG
from asictl.il.language import TC_MAX_VALUE as TC_MAX
from asictl.il.loader import Program
from asictl.platform.master import flag_keeps
from asictl.readers.units import timer_ticks
from asictl.runtime.firmware import FirmwareServices
from asictl.runtime.runner import CycleTimeout

#: The operand kinds, as the patterns below name them.
K = ast.OperandKind


@dataclass
class PlcState:
    """Everything a program can see. Data images hold two slaves per byte, 2n in the low
    nibble, exactly as the master's data images and the IB/QB byte operands do."""

    inputs: bytearray = field(default_factory=lambda: bytearray(16))
    old_inputs: bytearray = field(default_factory=lambda: bytearray(16))
    outputs: bytearray = field(default_factory=lambda: bytearray(16))
    flags: bytearray = field(default_factory=lambda: bytearray(128))
    pseg: bytearray = field(default_factory=lambda: bytearray(16))
    timers: dict[int, int] = field(default_factory=dict)
    counters: dict[int, int] = field(default_factory=dict)
    variables: dict[str, bytearray] = field(default_factory=dict)
    accu1: int = 0
    accu2: int = 0
    #: the single-bit register (RLO)
    rlo: bool = False
    #: the constant register loaded by L KT (in 10 ms ticks), L KC and L KP (address*16+data)
    constant: int = 0

    def copy(self) -> PlcState:
        """A state of its own to run on while this one stays as it is. The searches that
        branch take one per branch (the falsifier, exhaustive runs), where
        ``copy.deepcopy`` took about twenty times as long. The timer table is copied with
        ``copy.copy``, so that a table of the falsifier's own kind stays one."""
        return replace(
            self, inputs=self.inputs.copy(), old_inputs=self.old_inputs.copy(),
            outputs=self.outputs.copy(), flags=self.flags.copy(), pseg=self.pseg.copy(),
            timers=copy.copy(self.timers), counters=self.counters.copy(),
            variables={name: value.copy() for name, value in self.variables.items()},
        )


def _image_bit(image: bytearray, address: int, bit: int) -> bool:
    return bool(image[address >> 1] >> ((address & 1) * 4 + bit) & 1)


def _set_image_bit(image: bytearray, address: int, bit: int, value: bool) -> None:
    mask = 1 << ((address & 1) * 4 + bit)
    image[address >> 1] = image[address >> 1] | mask if value else image[address >> 1] & ~mask


@dataclass
class Scope:
    """One executable body: the main program or a function block."""

    statements: list[ast.Statement | ast.GatingLine]
    labels: dict[str, int]
    first_check: set[int]


def scope_of(module: ast.Module) -> Scope:
    """Flatten PROGRAM and GATING sections in source order; find labels and first checks.

    A first check is an A/AN/O/ON that loads the register: the first one of the block,
    of each section and after each ***. The rule is lexical: jumps do not change it.
    """
    statements: list[ast.Statement | ast.GatingLine] = []
    first_check: set[int] = set()
    for section in module.sections:
        if isinstance(section, ast.GatingSection):
            statements.extend(section.lines)
        elif isinstance(section, ast.ProgramSection):
            first = True
            for statement in section.statements:
                if isinstance(statement, ast.SegmentEnd):
                    first = True
                elif isinstance(statement, ast.Logic):
                    if first:
                        first_check.add(len(statements))
                    first = False
                elif isinstance(statement, ast.Compare):
                    first = False
                statements.append(statement)
    labels = {key(s.name): i for i, s in enumerate(statements) if isinstance(s, ast.Label)}
    return Scope(statements, labels, first_check)


def runs_alone(program: Program, *, firmware_answers: bool = False) -> bool:
    """No PARAM, no ASM, and no firmware block call (unless the run gives firmware
    blocks answers: ``firmware_answers``): the program's every cycle is decided by its
    inputs (and those answers) alone, so such a run is a run of the master."""
    for module in program.modules():
        if module.has_assembly():
            return False
        for node in module.code():
            if isinstance(node, ast.Param):
                return False
            if (not firmware_answers and isinstance(node, ast.CallFB)
                    and key(node.name) not in program.blocks):
                return False
    return True


class Interpreter:
    """Runs a checked program cycle by cycle, as the master would."""

    def __init__(
        self,
        program: Program,
        *,
        firmware: FirmwareServices | None = None,
        map_counters: bool | None = None,
        budget: int = 100_000,
    ) -> None:
        self.program = program
        self.firmware = firmware
        self.budget = budget
        if map_counters is None:
            map_counters = any(
                key(o.name) == "map_counters" and o.value
                for s in program.main.sections_of(ast.OptionsSection)
                for o in s.options
            )
        self.map_counters = map_counters
        self.main = scope_of(program.main)
        self.blocks = {name: scope_of(module) for name, module in program.blocks.items()}
        self.sizes = {
            key(d.name): d.size
            for m in program.modules()
            for s in m.sections_of(ast.DeclSection)
            for d in s.declarations
            if isinstance(d, ast.VarDecl)
        }
        self.state = PlcState()
        #: called before each statement runs (per-line traces compare against this)
        self.on_statement: Callable[[ast.Statement | ast.GatingLine], None] | None = None
        self.reset()

    def reset(self) -> None:
        """What reset_bit does: clear flags, timers, counters, variables and the images."""
        self.state = PlcState(variables={name: bytearray(n) for name, n in self.sizes.items()})

    # ------------------------------------------------------------------ the cycle

    def cycle(self, inputs: bytes | None = None) -> None:
        """One program cycle: new inputs (the old ones become I2), run, outputs stay in Q.

        The register starts every cycle at 0; accumulators and the constant register keep
        their values, like every other memory of the program.
        """
        state = self.state
        state.old_inputs[:] = state.inputs
        if inputs is not None:
            state.inputs[:] = inputs
        state.rlo = False
        self._steps = 0
        self._run(self.main)

    def tick(self, ticks: int = 1) -> None:
        """Advance master time by ``ticks`` x 10 ms: every running timer counts down."""
        timers = self.state.timers
        for number, remaining in timers.items():
            timers[number] = max(0, remaining - ticks)

    # ------------------------------------------------------------------ execution

    def _run(self, scope: Scope) -> None:
        state = self.state
        statements = scope.statements
        pc = 0
        while pc < len(statements):
            self._steps += 1
            if self._steps > self.budget:
                raise CycleTimeout(f"more than {self.budget} instructions in one cycle")
            statement = statements[pc]
            pc += 1
            if self.on_statement is not None:
                self.on_statement(statement)
            match statement:
                case ast.Logic(op=op, operand=operand):
                    value = self._read_bit(operand)
                    if op in (ast.LogicOp.AN, ast.LogicOp.ON):
                        value = not value
                    if pc - 1 in scope.first_check:
                        state.rlo = value
                    elif op in (ast.LogicOp.A, ast.LogicOp.AN):
                        state.rlo = state.rlo and value
                    else:
                        state.rlo = state.rlo or value
                case ast.Store(op=op, operand=operand):
                    self._store(op, operand)
                case ast.Not():
                    state.rlo = not state.rlo
                case ast.Load(operand=operand):
                    self._load(operand)
                case ast.Transfer(operand=operand):
                    self._transfer(operand)
                case ast.Arith(op=op):
                    a2, a1 = state.accu2 & 0xFF, state.accu1 & 0xFF
                    state.accu1 = (a2 + a1 if op is ast.ArithOp.ADD else a2 - a1) & 0xFF
                case ast.Compare(op=op):
                    state.rlo = _COMPARE[op](state.accu2 & 0xFF, state.accu1 & 0xFF)
                case ast.Count(op=op, counter=counter):
                    self._count(op, counter.address)
                case ast.SegmentEnd() | ast.Label():
                    pass
                case ast.BlockEnd(kind=kind):
                    if kind is not ast.EndKind.BEC or state.rlo:
                        return
                case ast.Jump(conditional=conditional, label=label):
                    if not conditional or state.rlo:
                        pc = scope.labels[key(label)]
                case ast.CallFB(conditional=conditional, name=name):
                    if not conditional or state.rlo:
                        self._call(name)
                case ast.Param():
                    if state.rlo:
                        self._param()
                case ast.GatingLine():
                    self._gate(statement)
                case ast.Asm():
                    raise NotImplementedError("the reference interpreter cannot run ASM lines")
                case _:
                    assert_never(statement)

    def _call(self, name: str) -> None:
        block = self.blocks.get(key(name))
        if block is not None:
            self._run(block)
        elif self.firmware is not None:
            self.firmware.call(name, self.state.pseg)

    def _param(self) -> None:
        """PARAM is SendPrm with the KP register: slave address and parameter via PSeg."""
        state = self.state
        state.pseg[0] = state.constant >> 4 & 0x1F
        state.pseg[1] = state.constant & 0x0F
        if self.firmware is not None:
            self.firmware.call("SendPrm", state.pseg)
        ok = state.pseg[0] == 0
        answer = state.pseg[1] & 0x0F if ok else 0
        state.flags[PARAM_FLAG] = (state.flags[PARAM_FLAG] & 0x70) | answer | (0x80 if ok else 0)

    def _gate(self, line: ast.GatingLine) -> None:
        result = False
        for term in line.terms:
            value = self._read_bit(term.operand) != term.negated
            if term.op is ast.GatingOp.AND:
                result = result and value
            elif term.op is ast.GatingOp.OR:
                result = result or value
            else:
                result = value
        self.state.rlo = result
        self._store(ast.StoreOp.ASSIGN, line.target)

    # ------------------------------------------------------------------ operands

    def _read_bit(self, operand: ast.Operand) -> bool:
        state = self.state
        address, bit = operand.address, operand.bit
        match operand.kind:
            case K.F:
                return bool(state.flags[address] >> bit & 1)
            case K.I | K.I2 | K.Q:
                return _image_bit(self._image(operand.kind), address, bit)
            case K.T:
                return state.timers.get(address, 0) != 0
            case K.C:
                return self._counter(address) != 0
            case K.VAR:
                return bool(state.variables[key(operand.name)][address] >> bit & 1)
            case (K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.FW | K.KT | K.KC | K.KB | K.KW
                  | K.KP):
                raise AssertionError(f"{operand} is no bit operand")
            case _:
                assert_never(operand.kind)

    def _image(self, kind: ast.OperandKind) -> bytearray:
        state = self.state
        return {K.I: state.inputs, K.I2: state.old_inputs, K.Q: state.outputs}[kind]

    def _store(self, op: ast.StoreOp, operand: ast.Operand) -> None:
        state = self.state
        if operand.kind is K.T:
            if state.rlo:
                state.timers[operand.address] = (
                    min(state.constant, TC_MAX) if op is ast.StoreOp.SET else 0
                )
            return
        if operand.kind is K.C:
            if state.rlo:
                value = min(state.constant, TC_MAX) if op is ast.StoreOp.SET else 0
                self._set_counter(operand.address, value)
            return
        if op is ast.StoreOp.ASSIGN:
            value = state.rlo
        elif not state.rlo:
            return
        else:
            value = op is ast.StoreOp.SET
        address, bit = operand.address, operand.bit
        match operand.kind:
            case K.F:
                _set_bit(state.flags, address, bit, value)
                state.flags[address] &= flag_keeps(address, self.map_counters)
            case K.I | K.I2 | K.Q:
                _set_image_bit(self._image(operand.kind), address, bit, value)
            case K.VAR:
                _set_bit(state.variables[key(operand.name)], address, bit, value)
            case (K.T | K.C | K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.FW | K.KT | K.KC | K.KB
                  | K.KW | K.KP):
                raise AssertionError(f"{operand} is no bit operand")
            case _:
                assert_never(operand.kind)

    def _load(self, operand: ast.Operand) -> None:
        state = self.state
        kind = operand.kind  # KT, KC and KP load the constant register, the rest ACCU1
        if kind is K.KT:
            state.constant = timer_ticks(operand.address)
        elif kind is K.KC:
            state.constant = operand.address
        elif kind is K.KP:
            state.constant = operand.address << 4 | operand.bit
        else:
            state.accu2 = state.accu1
            state.accu1 = self._read_word(operand)

    def _read_word(self, operand: ast.Operand) -> int:
        """What ``L`` puts in ACCU1: a constant, a word, a byte."""
        state = self.state
        n = operand.address
        match operand.kind:
            case K.KB | K.KW:
                return n
            case K.FW:
                return state.flags[n] << 8 | state.flags[n + 1]
            case K.T:
                return state.timers.get(n, 0)
            case K.C:
                return self._counter(n)
            case K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.VAR:
                buffer, index = self._byte_location(operand)
                return buffer[index]
            case K.I | K.I2 | K.Q | K.F | K.KT | K.KC | K.KP:
                raise AssertionError(f"L {operand} loads no word")
            case _:
                assert_never(operand.kind)

    def _transfer(self, operand: ast.Operand) -> None:
        state = self.state
        value = state.accu1
        n = operand.address
        match operand.kind:
            case K.FW:
                state.flags[n] = value >> 8 & flag_keeps(n, self.map_counters)
                state.flags[n + 1] = value & flag_keeps(n + 1, self.map_counters)
            case K.T:
                state.timers[n] = min(value, TC_MAX)
            case K.C:
                self._set_counter(n, min(value, TC_MAX))
            case K.FY:
                state.flags[n] = value & flag_keeps(n, self.map_counters)
            case K.IB | K.I2B | K.QB | K.PSEG | K.VAR:
                buffer, index = self._byte_location(operand)
                buffer[index] = value & 0xFF
            case K.I | K.I2 | K.Q | K.F | K.KT | K.KC | K.KB | K.KW | K.KP:
                raise AssertionError(f"T {operand} writes no word")
            case _:
                assert_never(operand.kind)

    def _byte_location(self, operand: ast.Operand) -> tuple[bytearray, int]:
        state = self.state
        n = operand.address
        match operand.kind:
            case K.IB:
                return state.inputs, n >> 1
            case K.I2B:
                return state.old_inputs, n >> 1
            case K.QB:
                return state.outputs, n >> 1
            case K.FY:
                return state.flags, n
            case K.PSEG:
                return state.pseg, n
            case K.VAR:
                return state.variables[key(operand.name)], n
            case (K.I | K.I2 | K.Q | K.F | K.FW | K.T | K.C | K.KT | K.KC | K.KB | K.KW
                  | K.KP):
                raise AssertionError(f"{operand} is no byte operand")
            case _:
                assert_never(operand.kind)

    # ------------------------------------------------------------------ counters

    def _counter(self, n: int) -> int:
        if self.map_counters and n < MAPPED_COUNTERS:
            flags = self.state.flags
            return (flags[COUNTER_FLAG_BASE + 2 * n + 1] & 0x0F) << 8 | flags[
                COUNTER_FLAG_BASE + 2 * n
            ]
        return self.state.counters.get(n, 0)

    def _set_counter(self, n: int, value: int) -> None:
        if self.map_counters and n < MAPPED_COUNTERS:
            self.state.flags[COUNTER_FLAG_BASE + 2 * n] = value & 0xFF
            self.state.flags[COUNTER_FLAG_BASE + 2 * n + 1] = value >> 8
        else:
            self.state.counters[n] = value

    def _count(self, op: ast.CountOp, n: int) -> None:
        rlo = self.state.rlo
        if op is ast.CountOp.STP:
            step = 1 if rlo else -1
        elif not rlo:
            return
        else:
            step = 1 if op is ast.CountOp.CU else -1
        self._set_counter(n, max(0, min(TC_MAX, self._counter(n) + step)))


def _set_bit(buffer: bytearray, index: int, bit: int, value: bool) -> None:
    buffer[index] = buffer[index] | 1 << bit if value else buffer[index] & ~(1 << bit)


_COMPARE: dict[ast.CompareOp, Callable[[int, int], bool]] = {
    ast.CompareOp.EQ: lambda a, b: a == b,
    ast.CompareOp.NE: lambda a, b: a != b,
    ast.CompareOp.GT: lambda a, b: a > b,
    ast.CompareOp.GE: lambda a, b: a >= b,
    ast.CompareOp.LT: lambda a, b: a < b,
    ast.CompareOp.LE: lambda a, b: a <= b,
}
