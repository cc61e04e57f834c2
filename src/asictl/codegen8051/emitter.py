"""Instruction selection: IL statements to 8051 assembly (docs/runtime.md).

The IL machine maps onto the 8051 directly: the single-bit register is the carry flag,
so A/AN/O/ON/= are single ``MOV/ANL/ORL C,bit`` instructions on bit-addressable cells;
ACCU1/ACCU2 and the constant register are register pairs of bank 0. The emitter tracks
what ACC and DPTR hold along straight-line code, so a run of operations on one byte reads
it once. Every instruction is built as an object (``stream.Insn``) with the IL span it
implements and written into the output stream, which applies the peephole rules, lays
the code out and assembles it.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import Literal, assert_never

from asictl.codegen8051.allocate import bit_cell, byte_cell
from asictl.codegen8051.stream import (
    AT_DPTR,
    DPH,
    DPL,
    DPTR,
    R0,
    R1,
    R2,
    R3,
    R4,
    R5,
    R6,
    R7,
    A,
    Bit,
    C,
    Direct,
    Imm,
    Insn,
    Operand,
    OutputStream,
    Ref,
    Reg,
    acc_bit,
)
from asictl.diagnostics import Span
from asictl.il import ast
from asictl.il.ast import key
from asictl.il.language import PARAM_FLAG
from asictl.platform.master import flag_keeps
from asictl.readers.units import timer_ticks
from asictl.runtime import layout
from asictl.runtime.firmware import FIRMWARE_BLOCKS
from asictl.runtime.program_map import CellKind, Location, ProgramMap, Space, timer_status

K = ast.OperandKind


def label_symbol(scope: str | None, name: str) -> str:
    """``?U<label>`` (3.6.1); labels of a block get the block's name too, as scopes differ."""
    return f"?U{key(name)}" if scope is None else f"?U{scope}?{key(name)}"


def block_symbol(name: str) -> str:
    return f"_U?{key(name)}_"


def firmware_symbol(name: str) -> str:
    return f"_{FIRMWARE_BLOCKS[key(name)].name}_"


def timer_symbol(n: int) -> str:
    return f"_?Tci{n}_"


def counter_symbol(n: int) -> str:
    return f"_?Cci{n}_"


PSEG_SYMBOL = "_?PSeg_"
ENTRY_SYMBOL = "?MAIN"
#: What a bit is written with: the carry, 1 or 0.
BitValue = Literal["C", "1", "0"]


@dataclass
class Emitter:
    """Selects the instructions of a whole program and writes them into ``out``."""

    pmap: ProgramMap
    out: OutputStream = field(default_factory=OutputStream)
    #: the IL span the instructions emitted now implement
    span: Span | None = None
    _acc: Location | None = None
    _dptr: int | None = None
    _local: int = 0
    _helpers: set[str] = field(default_factory=set)

    # ----------------------------------------------------------------- plumbing

    def emit(self, mnemonic: str, *operands: Operand) -> None:
        self.out.emit(Insn(mnemonic, operands, self.span))

    def label(self, name: str) -> None:
        self.out.label(name, self.span)
        self.forget()

    def forget(self) -> None:
        """At a join point or after foreign code nothing is known about ACC and DPTR."""
        self._acc = None
        self._dptr = None

    def local(self) -> str:
        self._local += 1
        return f"?L{self._local}"

    def dptr(self, address: int) -> None:
        if self._dptr != address:
            self.emit("MOV", DPTR, Imm(address))
            self._dptr = address

    def load_acc(self, location: Location) -> None:
        """ACC := the byte at ``location``, unless it already holds it."""
        if self._acc == location:
            return
        if location.space is Space.IRAM:
            self.emit("MOV", A, Direct(location.address))
        else:
            self.dptr(location.address)
            self.emit("MOVX", A, AT_DPTR)
        self._acc = location

    def store_acc(self, location: Location) -> None:
        if location.space is Space.IRAM:
            self.emit("MOV", Direct(location.address), A)
        else:
            self.dptr(location.address)
            self.emit("MOVX", AT_DPTR, A)
        self._acc = location

    def acc_changed(self) -> None:
        self._acc = None

    def skip_unless_rlo(self) -> str:
        """Emit JNC over the code that follows; return the label to place after it."""
        skip = self.local()
        self.emit("JNC", Ref(skip))
        return skip

    def end_skip(self, skip: str) -> None:
        self.label(skip)

    # --------------------------------------------------------------- bit operands

    def bit_location(self, operand: ast.Operand) -> tuple[Location, int] | None:
        """Cell location and bit of an operand; None for a counter (computed status)."""
        match operand.kind:
            case K.I | K.I2 | K.Q | K.F:
                cell, bit = bit_cell(operand)
                if cell[0] is CellKind.F:
                    return self.pmap.flag(cell[1]), bit
                return self.pmap.cells[cell], bit
            case K.T:
                cell, bit = timer_status(operand.address)
                return self.pmap.cells[cell], bit
            case K.VAR:
                var = self.pmap.variables[key(operand.name)]
                return Location(Space.XDATA, var.address + operand.address), operand.bit
            case K.C:
                return None
            case (K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.FW | K.KT | K.KC | K.KB | K.KW
                  | K.KP):
                raise AssertionError(f"{operand} is no bit operand")
            case _:
                assert_never(operand.kind)

    def bit_source(self, operand: ast.Operand) -> Bit:
        """Prepare a bit operand for MOV/ANL/ORL C,bit and return the bit to name."""
        placed = self.bit_location(operand)
        if placed is None:
            self.counter_status(operand.address)
            return Bit(layout.STATUS_BIT)
        location, bit = placed
        if location.bit_addressable:
            return Bit(location.bit_address(bit))
        self.load_acc(location)
        return acc_bit(bit)

    def counter_status(self, n: int) -> None:
        """PSW.1 := (count of counter n is not 0), leaving the carry alone."""
        self.dptr(self.pmap.counters[n])
        zero = self.local()
        self.read_word_at_dptr(R0, mask_high=True)
        self.emit("ORL", A, R0)
        self.emit("CLR", Bit(layout.STATUS_BIT))
        self.emit("JZ", Ref(zero))
        self.emit("SETB", Bit(layout.STATUS_BIT))
        self.label(zero)

    def write_bit(self, location: Location, bit: int, value: BitValue) -> None:
        """operand bit := carry ('C'), 1 ('1') or 0 ('0'); the carry is kept."""
        if location.bit_addressable:
            self._set_bit(Bit(location.bit_address(bit)), value)
            if self._acc == location:
                self.acc_changed()
            return
        if location.space is Space.IRAM and value != "C":
            if value == "1":
                self.emit("ORL", Direct(location.address), Imm(1 << bit))
            else:
                self.emit("ANL", Direct(location.address), Imm(~(1 << bit) & 0xFF))
            if self._acc == location:
                self.acc_changed()
            return
        self.load_acc(location)
        self._set_bit(acc_bit(bit), value)
        self.store_acc(location)

    def _set_bit(self, target: Bit, value: BitValue) -> None:
        match value:
            case "C":
                self.emit("MOV", target, C)
            case "1":
                self.emit("SETB", target)
            case "0":
                self.emit("CLR", target)
            case _:
                assert_never(value)

    # ----------------------------------------------------------------- statements

    def logic(self, op: ast.LogicOp, operand: ast.Operand, first: bool) -> None:
        source = self.bit_source(operand)
        inverted = op in (ast.LogicOp.AN, ast.LogicOp.ON)
        if first:
            self.emit("MOV", C, source)
            if inverted:
                self.emit("CPL", C)
        else:
            mnemonic = "ANL" if op in (ast.LogicOp.A, ast.LogicOp.AN) else "ORL"
            self.emit(mnemonic, C, replace(source, negated=inverted))

    def store(self, op: ast.StoreOp, operand: ast.Operand) -> None:
        if operand.kind is K.T:
            self.timer_set_reset(op, operand.address)
            return
        if operand.kind is K.C:
            self.counter_set_reset(op, operand.address)
            return
        keeps = flag_keeps(operand.address, self.pmap.map_counters)
        if operand.kind is K.F and not keeps >> operand.bit & 1:
            return  # bits 4-7 of a mapped counter's high byte stay 0: the write changes nothing
        placed = self.bit_location(operand)
        assert placed is not None
        location, bit = placed
        if op is ast.StoreOp.ASSIGN:
            self.write_bit(location, bit, "C")
            return
        if location.space is Space.XDATA:
            self.dptr(location.address)  # outside the skipped code, so still known after it
        skip = self.skip_unless_rlo()
        acc = self._acc
        self.write_bit(location, bit, "1" if op is ast.StoreOp.SET else "0")
        self.end_skip(skip)
        if location.space is Space.XDATA:
            self._dptr = location.address
        if acc is not None and acc != location and location.space is Space.IRAM:
            self._acc = acc  # setting an IRAM bit leaves ACC as it was on both paths

    # --- timers and counters

    def timer_status_write(self, n: int, value: BitValue) -> None:
        cell, bit = timer_status(n)
        self.write_bit(self.pmap.cells[cell], bit, value)

    def timer_set_reset(self, op: ast.StoreOp, n: int) -> None:
        """S T n: remaining := constant register, status := it is not 0. R T n: stop."""
        skip = self.skip_unless_rlo()
        self.dptr(self.pmap.timers[n])
        if op is ast.StoreOp.SET:
            self.write_word_from(R2, R3)
            self.emit("ORL", A, R2)
            self.status_from_acc(n)
        else:
            self.clear_word()
            self.timer_status_write(n, "0")
        self.end_skip(skip)

    def clear_word(self) -> None:
        """The word at DPTR := 0."""
        self.emit("CLR", A)
        self.emit("MOVX", AT_DPTR, A)
        self.emit("INC", DPTR)
        self.emit("MOVX", AT_DPTR, A)

    def write_word_from(self, low: Reg, high: Reg) -> None:
        """Write two registers, low byte first, at DPTR; leaves ACC = the high byte."""
        self.emit("MOV", A, low)
        self.emit("MOVX", AT_DPTR, A)
        self.emit("INC", DPTR)
        self.emit("MOV", A, high)
        self.emit("MOVX", AT_DPTR, A)
        self._dptr = None if self._dptr is None else self._dptr + 1
        self.acc_changed()

    def read_word_at_dptr(self, low: Reg, *, mask_high: bool) -> None:
        """The word at DPTR: its low byte into ``low``, its high byte into ACC, DPTR left
        on the high byte (a counter counts in 12 bits: ``mask_high`` reads only those)."""
        self.emit("MOVX", A, AT_DPTR)
        self.emit("MOV", low, A)
        self.emit("INC", DPTR)
        self.emit("MOVX", A, AT_DPTR)
        if mask_high:
            self.emit("ANL", A, Imm(0x0F))
        self._dptr = None if self._dptr is None else self._dptr + 1
        self.acc_changed()

    def status_from_acc(self, n: int) -> None:
        """Timer n's status := ACC is not 0 (without touching the carry)."""
        zero, done = self.local(), self.local()
        self.emit("JZ", Ref(zero))
        self.timer_status_write(n, "1")
        self.emit("SJMP", Ref(done))
        self.label(zero)
        self.timer_status_write(n, "0")
        self.label(done)

    def counter_set_reset(self, op: ast.StoreOp, n: int) -> None:
        skip = self.skip_unless_rlo()
        self.dptr(self.pmap.counters[n])
        if op is ast.StoreOp.SET:
            self.write_word_from(R2, R3)
        else:
            self.clear_word()
        self.end_skip(skip)

    def count(self, op: ast.CountOp, n: int) -> None:
        self._helpers.update(("?CUP", "?CDN"))
        address = self.pmap.counters[n]
        if op is ast.CountOp.STP:
            down, done = self.local(), self.local()
            self.emit("MOV", DPTR, Imm(address))
            self.emit("JNC", Ref(down))
            self.emit("LCALL", Ref("?CUP"))
            self.emit("SJMP", Ref(done))
            self.label(down)
            self.emit("LCALL", Ref("?CDN"))
            self.label(done)
            return
        skip = self.skip_unless_rlo()
        self.emit("MOV", DPTR, Imm(address))
        self.emit("LCALL", Ref("?CUP" if op is ast.CountOp.CU else "?CDN"))
        self.end_skip(skip)

    # --- accumulators

    def push_accu(self) -> None:
        """ACCU2 := ACCU1."""
        self.emit("MOV", R5, Direct(layout.ACCU1_LO))
        self.emit("MOV", R4, Direct(layout.ACCU1_HI))

    def byte_location(self, operand: ast.Operand) -> Location:
        n = operand.address
        match operand.kind:
            case K.PSEG:
                return Location(Space.XDATA, self.pmap.pseg + n)
            case K.FY:
                return self.pmap.flag(n)
            case K.IB | K.I2B | K.QB:
                return self.pmap.cells[byte_cell(operand)]
            case K.VAR:
                return Location(Space.XDATA, self.pmap.variables[key(operand.name)].address + n)
            case (K.I | K.I2 | K.Q | K.F | K.FW | K.T | K.C | K.KT | K.KC | K.KB | K.KW
                  | K.KP):
                raise AssertionError(f"{operand} is no byte operand")
            case _:
                assert_never(operand.kind)

    def read_to(self, register: Reg, location: Location) -> None:
        if location.space is Space.IRAM:
            self.emit("MOV", register, Direct(location.address))
        else:
            self.load_acc(location)
            self.emit("MOV", register, A)

    def write_from(self, register: Reg, location: Location) -> None:
        if location.space is Space.IRAM:
            self.emit("MOV", Direct(location.address), register)
            if self._acc == location:
                self.acc_changed()
        else:
            self.emit("MOV", A, register)
            self.store_acc(location)

    def write_flag_from(self, register: Reg, n: int) -> None:
        """Flag byte n := the register, keeping only the bits the byte keeps (a mapped
        counter's high byte holds four)."""
        keeps = flag_keeps(n, self.pmap.map_counters)
        if keeps == 0xFF:
            self.write_from(register, self.pmap.flag(n))
            return
        self.emit("MOV", A, register)
        self.emit("ANL", A, Imm(keeps))
        self.store_acc(self.pmap.flag(n))

    def load(self, operand: ast.Operand) -> None:
        n = operand.address
        if operand.kind is K.KT:
            self.constant(timer_ticks(n))
            return
        if operand.kind is K.KC:
            self.constant(n)
            return
        if operand.kind is K.KP:
            self.constant(n << 4 | operand.bit)
            return
        self.push_accu()
        match operand.kind:
            case K.KB | K.KW:
                self.emit("MOV", R7, Imm(n & 0xFF))
                self.emit("MOV", R6, Imm(n >> 8))
            case K.FW:
                self.read_to(R6, self.pmap.flag(n))
                self.read_to(R7, self.pmap.flag(n + 1))
            case K.T:
                self.read_word(self.pmap.timers[n], mask_high=False)
            case K.C:
                self.read_word(self.pmap.counters[n], mask_high=True)
            case K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.VAR:
                self.read_to(R7, self.byte_location(operand))
                self.emit("MOV", R6, Imm(0))
            case K.I | K.I2 | K.Q | K.F | K.KT | K.KC | K.KP:
                raise AssertionError(f"L {operand} loads no word")
            case _:
                assert_never(operand.kind)

    def read_word(self, address: int, *, mask_high: bool) -> None:
        self.dptr(address)
        self.read_word_at_dptr(R7, mask_high=mask_high)
        self.emit("MOV", R6, A)

    def constant(self, value: int) -> None:
        self.emit("MOV", R2, Imm(value & 0xFF))
        self.emit("MOV", R3, Imm(value >> 8))

    def transfer(self, operand: ast.Operand) -> None:
        n = operand.address
        match operand.kind:
            case K.FW:
                self.write_flag_from(R6, n)
                self.write_flag_from(R7, n + 1)
            case K.T:
                self._helpers.add("?CLAMP")
                self.emit("LCALL", Ref("?CLAMP"))
                self.dptr(self.pmap.timers[n])
                self.write_word_from(R0, R1)
                self.emit("ORL", A, R0)
                self.status_from_acc(n)
            case K.C:
                self._helpers.add("?CLAMP")
                self.emit("LCALL", Ref("?CLAMP"))
                self.dptr(self.pmap.counters[n])
                self.write_word_from(R0, R1)
            case K.FY:
                self.write_flag_from(R7, n)
            case K.IB | K.I2B | K.QB | K.PSEG | K.VAR:
                self.write_from(R7, self.byte_location(operand))
            case K.I | K.I2 | K.Q | K.F | K.KT | K.KC | K.KB | K.KW | K.KP:
                raise AssertionError(f"T {operand} writes no word")
            case _:
                assert_never(operand.kind)

    def arith(self, op: ast.ArithOp) -> None:
        """ACCU1 := ACCU2 +/- ACCU1 on bytes; the register survives in PSW.F0."""
        self.emit("MOV", Bit(layout.SAVED_RLO_BIT), C)
        self.emit("MOV", A, R5)
        if op is ast.ArithOp.ADD:
            self.emit("ADD", A, R7)
        else:
            self.emit("CLR", C)
            self.emit("SUBB", A, R7)
        self.emit("MOV", R7, A)
        self.emit("MOV", R6, Imm(0))
        self.emit("MOV", C, Bit(layout.SAVED_RLO_BIT))
        self.acc_changed()

    def compare(self, op: ast.CompareOp) -> None:
        """register := ACCU2 op ACCU1, bytes unsigned, computed in the carry."""
        if op in (ast.CompareOp.EQ, ast.CompareOp.NE):
            self.emit("MOV", A, R5)
            self.emit("XRL", A, R7)
            self.emit("ADD", A, Imm(0xFF))  # carry := bytes differ
            if op is ast.CompareOp.EQ:
                self.emit("CPL", C)
        else:
            left, right = (R5, R7) if op in (ast.CompareOp.LT, ast.CompareOp.GE) else (R7, R5)
            self.emit("MOV", A, left)
            self.emit("CLR", C)
            self.emit("SUBB", A, right)  # carry := left < right
            if op in (ast.CompareOp.GE, ast.CompareOp.LE):
                self.emit("CPL", C)
        self.acc_changed()

    # --- execution control

    def jump(self, conditional: bool, target: str) -> None:
        """JU is a long jump; JC is left to the stream, which relaxes it to its reach."""
        if conditional:
            self.out.branch(target, self.span)
        else:
            self.emit("LJMP", Ref(target))

    def call(self, conditional: bool, name: str, user_blocks: Iterable[str]) -> None:
        skip = self.skip_unless_rlo() if conditional else None
        if key(name) in user_blocks:
            self.emit("LCALL", Ref(block_symbol(name)))
        else:
            self.emit("MOV", DPTR, Imm(PSEG_SYMBOL))
            self.emit("LCALL", Ref(firmware_symbol(name)))
        self.forget()
        if skip:
            self.end_skip(skip)

    def block_end(self, kind: ast.EndKind) -> None:
        if kind is ast.EndKind.BEC:
            skip = self.local()
            self.emit("JNC", Ref(skip))
            self.emit("RET")
            self.label(skip)
        else:
            self.emit("RET")

    def param(self) -> None:
        self._helpers.add("?PARAM")
        skip = self.skip_unless_rlo()
        self.emit("LCALL", Ref("?PARAM"))
        self.end_skip(skip)
        self.forget()

    def gating(self, line: ast.GatingLine) -> None:
        for i, term in enumerate(line.terms):
            op = {
                (None, False): ast.LogicOp.A, (None, True): ast.LogicOp.AN,
                (ast.GatingOp.AND, False): ast.LogicOp.A, (ast.GatingOp.AND, True): ast.LogicOp.AN,
                (ast.GatingOp.OR, False): ast.LogicOp.O, (ast.GatingOp.OR, True): ast.LogicOp.ON,
            }[(term.op, term.negated)]
            self.logic(op, term.operand, first=i == 0)
        self.store(ast.StoreOp.ASSIGN, line.target)

    def raw(self, text: str) -> None:
        """An ASM line or [ASSEMBLY] line: passed on; afterwards nothing is known."""
        self.out.raw(text, self.span)
        self.forget()

    # ------------------------------------------------------------ runtime helpers

    def helpers(self) -> None:
        """The subroutines the program used, each written once after the code."""
        self.span = None
        self.forget()
        if "?CUP" in self._helpers:
            self._counter_helper("?CUP", up=True)
        if "?CDN" in self._helpers:
            self._counter_helper("?CDN", up=False)
        if "?CLAMP" in self._helpers:
            self.label("?CLAMP")  # R1:R0 := min(ACCU1, 4095); keeps the carry
            self.emit("MOV", A, R7)
            self.emit("MOV", R0, A)
            self.emit("MOV", A, R6)
            self.emit("MOV", R1, A)
            self.emit("ANL", A, Imm(0xF0))
            self.emit("JZ", Ref("?CLAMP1"))
            self.emit("MOV", R0, Imm(0xFF))
            self.emit("MOV", R1, Imm(0x0F))
            self.label("?CLAMP1")
            self.emit("RET")
        if "?PARAM" in self._helpers:
            self._param_helper()

    def _counter_helper(self, name: str, *, up: bool) -> None:
        """Count the 12-bit counter at DPTR one step, saturating; keeps the carry."""
        self.label(name)
        self.emit("MOV", Bit(layout.SAVED_RLO_BIT), C)
        self.read_word_at_dptr(R0, mask_high=True)
        self.emit("MOV", R1, A)
        if up:
            self.emit("CJNE", R0, Imm(0xFF), Ref(f"{name}1"))
            self.emit("CJNE", R1, Imm(0x0F), Ref(f"{name}1"))
            self.emit("SJMP", Ref(f"{name}3"))  # 4095 stays 4095
            self.label(f"{name}1")
            self.emit("INC", R0)
            self.emit("CJNE", R0, Imm(0), Ref(f"{name}3"))
            self.emit("INC", R1)
        else:
            self.emit("ORL", A, R0)
            self.emit("JZ", Ref(f"{name}3"))  # 0 stays 0
            self.emit("MOV", A, R0)
            self.emit("JNZ", Ref(f"{name}2"))
            self.emit("DEC", R1)
            self.label(f"{name}2")
            self.emit("DEC", R0)
        self.label(f"{name}3")
        self.emit("MOV", A, R1)
        self.emit("MOVX", AT_DPTR, A)
        self.emit("MOV", A, DPL)
        self.emit("JNZ", Ref(f"{name}4"))
        self.emit("DEC", DPH)
        self.label(f"{name}4")
        self.emit("DEC", DPL)
        self.emit("MOV", A, R0)
        self.emit("MOVX", AT_DPTR, A)
        self.emit("MOV", C, Bit(layout.SAVED_RLO_BIT))
        self.emit("RET")

    def _param_helper(self) -> None:
        """PARAM: SendPrm with the constant register (a*16+d); answer into flag byte 127."""
        self.label("?PARAM")
        self.emit("MOV", DPTR, Imm(PSEG_SYMBOL))
        self.emit("MOV", A, R2)
        self.emit("SWAP", A)
        self.emit("ANL", A, Imm(0x0F))
        self.emit("MOV", R0, A)
        self.emit("MOV", A, R3)
        self.emit("SWAP", A)
        self.emit("ORL", A, R0)
        self.emit("ANL", A, Imm(0x1F))
        self.emit("MOVX", AT_DPTR, A)
        self.emit("INC", DPTR)
        self.emit("MOV", A, R2)
        self.emit("ANL", A, Imm(0x0F))
        self.emit("MOVX", AT_DPTR, A)
        self.emit("MOV", DPTR, Imm(PSEG_SYMBOL))
        self.emit("LCALL", Ref(firmware_symbol("SendPrm")))
        self.emit("MOV", DPTR, Imm(PSEG_SYMBOL))
        self.emit("MOVX", A, AT_DPTR)
        self.emit("JNZ", Ref("?PARAM1"))
        self.emit("INC", DPTR)
        self.emit("MOVX", A, AT_DPTR)
        self.emit("ANL", A, Imm(0x0F))
        self.emit("ORL", A, Imm(0x80))
        self.emit("SJMP", Ref("?PARAM2"))
        self.label("?PARAM1")
        self.emit("CLR", A)
        self.label("?PARAM2")
        self.emit("MOV", R0, A)
        flag = self.pmap.flag(PARAM_FLAG)
        self.load_acc(flag)
        self.emit("ANL", A, Imm(0x70))
        self.emit("ORL", A, R0)
        self.store_acc(flag)
        self.emit("SETB", C)
        self.emit("RET")
