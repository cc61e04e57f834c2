"""Instruction selection: IL statements to 8051 assembly (docs/runtime.md).

The IL machine maps onto the 8051 directly: the single-bit register is the carry flag,
so A/AN/O/ON/= are single ``MOV/ANL/ORL C,bit`` instructions on bit-addressable cells;
ACCU1/ACCU2 and the constant register are register pairs of bank 0. The emitter tracks
what ACC and DPTR hold along straight-line code, so a run of operations on one byte reads
it once. Every emitted line remembers the IL statement it implements, for the listing
and for mapping assembler errors back to IL source.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import assert_never

from asictl.codegen8051.allocate import bit_cell, byte_cell
from asictl.diagnostics import Span
from asictl.il import ast
from asictl.il.ast import key
from asictl.il.language import PARAM_FLAG
from asictl.runtime import layout
from asictl.runtime.firmware import FIRMWARE_BLOCKS
from asictl.runtime.program_map import CellKind, Location, ProgramMap, Space, timer_status

K = ast.OperandKind


def _hex(value: int) -> str:
    """An assembler number: 0A5h style, always starting with a digit."""
    return f"0{value:X}h"


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


@dataclass
class Line:
    """One line of generated assembly and the IL source it implements."""

    text: str
    span: Span | None


@dataclass
class Emitter:
    """Writes the assembly of a whole program."""

    pmap: ProgramMap
    #: conditional jumps (by their number) that must take the long form
    long_jumps: frozenset[int] = frozenset()
    lines: list[Line] = field(default_factory=list)
    #: which conditional jump each line holds, for relaxation after an out-of-range error
    jump_lines: dict[int, int] = field(default_factory=dict)
    span: Span | None = None
    _acc: Location | None = None
    _dptr: int | None = None
    _local: int = 0
    _jumps: int = 0
    _helpers: set[str] = field(default_factory=set)

    # ----------------------------------------------------------------- plumbing

    def emit(self, text: str) -> None:
        """Append an instruction, with the peephole rules that need only the previous line:
        a ``CLR C`` overwritten by ``MOV C,bit`` goes, and so does a second ``RET``."""
        last = self.lines[-1].text.strip() if self.lines else ""
        if last == "CLR C" and text.startswith("MOV C,"):
            self.lines.pop()
        elif last == "RET" and text == "RET":
            return
        self.lines.append(Line(f"        {text}", self.span))

    def label(self, name: str) -> None:
        """Place a label; a ``LJMP`` to it from the line just before is dropped."""
        if self.lines and self.lines[-1].text.strip() == f"LJMP {name}":
            self.lines.pop()
        self.lines.append(Line(f"{name}:", self.span))
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
            self.emit(f"MOV DPTR,#{_hex(address)}")
            self._dptr = address

    def load_acc(self, location: Location) -> None:
        """ACC := the byte at ``location``, unless it already holds it."""
        if self._acc == location:
            return
        if location.space is Space.IRAM:
            self.emit(f"MOV A,{_hex(location.address)}")
        else:
            self.dptr(location.address)
            self.emit("MOVX A,@DPTR")
        self._acc = location

    def store_acc(self, location: Location) -> None:
        if location.space is Space.IRAM:
            self.emit(f"MOV {_hex(location.address)},A")
        else:
            self.dptr(location.address)
            self.emit("MOVX @DPTR,A")
        self._acc = location

    def acc_changed(self) -> None:
        self._acc = None

    def skip_unless_rlo(self) -> str:
        """Emit JNC over the code that follows; return the label to place after it."""
        skip = self.local()
        self.emit(f"JNC {skip}")
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

    def bit_source(self, operand: ast.Operand) -> str:
        """Prepare a bit operand for MOV/ANL/ORL C,bit and return its bit name."""
        placed = self.bit_location(operand)
        if placed is None:
            self.counter_status(operand.address)
            return _hex(layout.STATUS_BIT)
        location, bit = placed
        if location.bit_addressable:
            return _hex(location.bit_address(bit))
        self.load_acc(location)
        return f"ACC.{bit}"

    def counter_status(self, n: int) -> None:
        """PSW.1 := (count of counter n is not 0), leaving the carry alone."""
        self.dptr(self.pmap.counters[n])
        zero = self.local()
        self.emit("MOVX A,@DPTR")
        self.emit("MOV R0,A")
        self.emit("INC DPTR")
        self.emit("MOVX A,@DPTR")
        self.emit("ANL A,#0Fh")
        self.emit("ORL A,R0")
        self.emit(f"CLR {_hex(layout.STATUS_BIT)}")
        self.emit(f"JZ {zero}")
        self.emit(f"SETB {_hex(layout.STATUS_BIT)}")
        self.label(zero)

    def write_bit(self, location: Location, bit: int, value: str) -> None:
        """operand bit := carry ('C'), 1 ('1') or 0 ('0'); the carry is kept."""
        if location.bit_addressable:
            name = _hex(location.bit_address(bit))
            self.emit({"C": f"MOV {name},C", "1": f"SETB {name}", "0": f"CLR {name}"}[value])
            if self._acc == location:
                self.acc_changed()
            return
        if location.space is Space.IRAM and value != "C":
            op = f"ORL {_hex(location.address)},#{_hex(1 << bit)}" if value == "1" else (
                f"ANL {_hex(location.address)},#{_hex(~(1 << bit) & 0xFF)}"
            )
            self.emit(op)
            if self._acc == location:
                self.acc_changed()
            return
        self.load_acc(location)
        self.emit({"C": f"MOV ACC.{bit},C", "1": f"SETB ACC.{bit}", "0": f"CLR ACC.{bit}"}[value])
        self.store_acc(location)

    # ----------------------------------------------------------------- statements

    def logic(self, op: ast.LogicOp, operand: ast.Operand, first: bool) -> None:
        source = self.bit_source(operand)
        inverted = op in (ast.LogicOp.AN, ast.LogicOp.ON)
        if first:
            self.emit(f"MOV C,{source}")
            if inverted:
                self.emit("CPL C")
        elif op in (ast.LogicOp.A, ast.LogicOp.AN):
            self.emit(f"ANL C,{'/' if inverted else ''}{source}")
        else:
            self.emit(f"ORL C,{'/' if inverted else ''}{source}")

    def store(self, op: ast.StoreOp, operand: ast.Operand) -> None:
        if operand.kind is K.T:
            self.timer_set_reset(op, operand.address)
            return
        if operand.kind is K.C:
            self.counter_set_reset(op, operand.address)
            return
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

    def timer_status_write(self, n: int, value: str) -> None:
        cell, bit = timer_status(n)
        self.write_bit(self.pmap.cells[cell], bit, value)

    def timer_set_reset(self, op: ast.StoreOp, n: int) -> None:
        """S T n: remaining := constant register, status := it is not 0. R T n: stop."""
        skip = self.skip_unless_rlo()
        self.dptr(self.pmap.timers[n])
        if op is ast.StoreOp.SET:
            self.write_word_from("R2", "R3")
            self.emit("ORL A,R2")
            self.status_from_acc(n)
        else:
            self.emit("CLR A")
            self.emit("MOVX @DPTR,A")
            self.emit("INC DPTR")
            self.emit("MOVX @DPTR,A")
            self.timer_status_write(n, "0")
        self.end_skip(skip)

    def write_word_from(self, low: str, high: str) -> None:
        """Write two registers, low byte first, at DPTR; leaves ACC = the high byte."""
        self.emit(f"MOV A,{low}")
        self.emit("MOVX @DPTR,A")
        self.emit("INC DPTR")
        self.emit(f"MOV A,{high}")
        self.emit("MOVX @DPTR,A")
        self._dptr = None if self._dptr is None else self._dptr + 1
        self.acc_changed()

    def status_from_acc(self, n: int) -> None:
        """Timer n's status := ACC is not 0 (without touching the carry)."""
        zero, done = self.local(), self.local()
        self.emit(f"JZ {zero}")
        self.timer_status_write(n, "1")
        self.emit(f"SJMP {done}")
        self.label(zero)
        self.timer_status_write(n, "0")
        self.label(done)

    def counter_set_reset(self, op: ast.StoreOp, n: int) -> None:
        skip = self.skip_unless_rlo()
        self.dptr(self.pmap.counters[n])
        if op is ast.StoreOp.SET:
            self.write_word_from("R2", "R3")
        else:
            self.emit("CLR A")
            self.emit("MOVX @DPTR,A")
            self.emit("INC DPTR")
            self.emit("MOVX @DPTR,A")
        self.end_skip(skip)

    def count(self, op: ast.CountOp, n: int) -> None:
        self._helpers.update(("?CUP", "?CDN"))
        address = self.pmap.counters[n]
        if op is ast.CountOp.STP:
            down, done = self.local(), self.local()
            self.emit(f"MOV DPTR,#{_hex(address)}")
            self.emit(f"JNC {down}")
            self.emit("LCALL ?CUP")
            self.emit(f"SJMP {done}")
            self.label(down)
            self.emit("LCALL ?CDN")
            self.label(done)
            return
        skip = self.skip_unless_rlo()
        self.emit(f"MOV DPTR,#{_hex(address)}")
        self.emit("LCALL ?CUP" if op is ast.CountOp.CU else "LCALL ?CDN")
        self.end_skip(skip)

    # --- accumulators

    def push_accu(self) -> None:
        """ACCU2 := ACCU1."""
        self.emit(f"MOV R5,{_hex(layout.ACCU1_LO)}")
        self.emit(f"MOV R4,{_hex(layout.ACCU1_HI)}")

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

    def read_to(self, register: str, location: Location) -> None:
        if location.space is Space.IRAM:
            self.emit(f"MOV {register},{_hex(location.address)}")
        else:
            self.load_acc(location)
            self.emit(f"MOV {register},A")

    def write_from(self, register: str, location: Location) -> None:
        if location.space is Space.IRAM:
            self.emit(f"MOV {_hex(location.address)},{register}")
            if self._acc == location:
                self.acc_changed()
        else:
            self.emit(f"MOV A,{register}")
            self.store_acc(location)

    def load(self, operand: ast.Operand) -> None:
        n = operand.address
        if operand.kind is K.KT:
            self.constant((n + 9) // 10)
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
                self.emit(f"MOV R7,#{_hex(n & 0xFF)}")
                self.emit(f"MOV R6,#{_hex(n >> 8)}")
            case K.FW:
                self.read_to("R6", self.pmap.flag(n))
                self.read_to("R7", self.pmap.flag(n + 1))
            case K.T:
                self.read_word(self.pmap.timers[n], mask_high=False)
            case K.C:
                self.read_word(self.pmap.counters[n], mask_high=True)
            case K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.VAR:
                self.read_to("R7", self.byte_location(operand))
                self.emit("MOV R6,#0")
            case K.I | K.I2 | K.Q | K.F | K.KT | K.KC | K.KP:
                raise AssertionError(f"L {operand} loads no word")
            case _:
                assert_never(operand.kind)

    def read_word(self, address: int, *, mask_high: bool) -> None:
        self.dptr(address)
        self.emit("MOVX A,@DPTR")
        self.emit("MOV R7,A")
        self.emit("INC DPTR")
        self.emit("MOVX A,@DPTR")
        if mask_high:
            self.emit("ANL A,#0Fh")
        self.emit("MOV R6,A")
        self._dptr = address + 1
        self.acc_changed()

    def constant(self, value: int) -> None:
        self.emit(f"MOV R2,#{_hex(value & 0xFF)}")
        self.emit(f"MOV R3,#{_hex(value >> 8)}")

    def transfer(self, operand: ast.Operand) -> None:
        n = operand.address
        match operand.kind:
            case K.FW:
                self.write_from("R6", self.pmap.flag(n))
                self.write_from("R7", self.pmap.flag(n + 1))
            case K.T:
                self._helpers.add("?CLAMP")
                self.emit("LCALL ?CLAMP")
                self.dptr(self.pmap.timers[n])
                self.write_word_from("R0", "R1")
                self.emit("ORL A,R0")
                self.status_from_acc(n)
            case K.C:
                self._helpers.add("?CLAMP")
                self.emit("LCALL ?CLAMP")
                self.dptr(self.pmap.counters[n])
                self.write_word_from("R0", "R1")
            case K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.VAR:
                self.write_from("R7", self.byte_location(operand))
            case K.I | K.I2 | K.Q | K.F | K.KT | K.KC | K.KB | K.KW | K.KP:
                raise AssertionError(f"T {operand} writes no word")
            case _:
                assert_never(operand.kind)

    def arith(self, op: ast.ArithOp) -> None:
        """ACCU1 := ACCU2 +/- ACCU1 on bytes; the register survives in PSW.F0."""
        self.emit(f"MOV {_hex(layout.SAVED_RLO_BIT)},C")
        self.emit("MOV A,R5")
        if op is ast.ArithOp.ADD:
            self.emit("ADD A,R7")
        else:
            self.emit("CLR C")
            self.emit("SUBB A,R7")
        self.emit("MOV R7,A")
        self.emit("MOV R6,#0")
        self.emit(f"MOV C,{_hex(layout.SAVED_RLO_BIT)}")
        self.acc_changed()

    def compare(self, op: ast.CompareOp) -> None:
        """register := ACCU2 op ACCU1, bytes unsigned, computed in the carry."""
        if op in (ast.CompareOp.EQ, ast.CompareOp.NE):
            self.emit("MOV A,R5")
            self.emit("XRL A,R7")
            self.emit("ADD A,#0FFh")  # carry := bytes differ
            if op is ast.CompareOp.EQ:
                self.emit("CPL C")
        else:
            left, right = ("R5", "R7") if op in (ast.CompareOp.LT, ast.CompareOp.GE) else (
                "R7", "R5"
            )
            self.emit(f"MOV A,{left}")
            self.emit("CLR C")
            self.emit(f"SUBB A,{right}")  # carry := left < right
            if op in (ast.CompareOp.GE, ast.CompareOp.LE):
                self.emit("CPL C")
        self.acc_changed()

    # --- execution control

    def jump(self, conditional: bool, target: str) -> None:
        if not conditional:
            self.emit(f"LJMP {target}")
            return
        self._jumps += 1
        number = self._jumps
        self.jump_lines[len(self.lines)] = number
        if number in self.long_jumps:
            skip = self.local()
            self.emit(f"JNC {skip}")
            self.emit(f"LJMP {target}")
            self.label(skip)
        else:
            self.emit(f"JC {target}")

    def call(self, conditional: bool, name: str, user_blocks: Iterable[str]) -> None:
        skip = self.skip_unless_rlo() if conditional else None
        if key(name) in user_blocks:
            self.emit(f"LCALL {block_symbol(name)}")
        else:
            self.emit(f"MOV DPTR,#{PSEG_SYMBOL}")
            self.emit(f"LCALL {firmware_symbol(name)}")
        self.forget()
        if skip:
            self.end_skip(skip)

    def block_end(self, kind: ast.EndKind) -> None:
        if kind is ast.EndKind.BEC:
            skip = self.local()
            self.emit(f"JNC {skip}")
            self.emit("RET")
            self.label(skip)
        else:
            self.emit("RET")

    def param(self) -> None:
        self._helpers.add("?PARAM")
        skip = self.skip_unless_rlo()
        self.emit("LCALL ?PARAM")
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
        self.lines.append(Line(text, self.span))
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
            self.emit("MOV A,R7")
            self.emit("MOV R0,A")
            self.emit("MOV A,R6")
            self.emit("MOV R1,A")
            self.emit("ANL A,#0F0h")
            self.emit("JZ ?CLAMP1")
            self.emit("MOV R0,#0FFh")
            self.emit("MOV R1,#0Fh")
            self.label("?CLAMP1")
            self.emit("RET")
        if "?PARAM" in self._helpers:
            self._param_helper()

    def _counter_helper(self, name: str, *, up: bool) -> None:
        """Count the 12-bit counter at DPTR one step, saturating; keeps the carry."""
        self.label(name)
        self.emit(f"MOV {_hex(layout.SAVED_RLO_BIT)},C")
        self.emit("MOVX A,@DPTR")
        self.emit("MOV R0,A")
        self.emit("INC DPTR")
        self.emit("MOVX A,@DPTR")
        self.emit("ANL A,#0Fh")
        self.emit("MOV R1,A")
        if up:
            self.emit(f"CJNE R0,#0FFh,{name}1")
            self.emit(f"CJNE R1,#0Fh,{name}1")
            self.emit(f"SJMP {name}3")  # 4095 stays 4095
            self.label(f"{name}1")
            self.emit("INC R0")
            self.emit(f"CJNE R0,#0,{name}3")
            self.emit("INC R1")
        else:
            self.emit("ORL A,R0")
            self.emit(f"JZ {name}3")  # 0 stays 0
            self.emit("MOV A,R0")
            self.emit(f"JNZ {name}2")
            self.emit("DEC R1")
            self.label(f"{name}2")
            self.emit("DEC R0")
        self.label(f"{name}3")
        self.emit("MOV A,R1")
        self.emit("MOVX @DPTR,A")
        self.emit("MOV A,DPL")
        self.emit(f"JNZ {name}4")
        self.emit("DEC DPH")
        self.label(f"{name}4")
        self.emit("DEC DPL")
        self.emit("MOV A,R0")
        self.emit("MOVX @DPTR,A")
        self.emit(f"MOV C,{_hex(layout.SAVED_RLO_BIT)}")
        self.emit("RET")

    def _param_helper(self) -> None:
        """PARAM: SendPrm with the constant register (a*16+d); answer into flag byte 127."""
        self.label("?PARAM")
        self.emit(f"MOV DPTR,#{PSEG_SYMBOL}")
        self.emit("MOV A,R2")
        self.emit("SWAP A")
        self.emit("ANL A,#0Fh")
        self.emit("MOV R0,A")
        self.emit("MOV A,R3")
        self.emit("SWAP A")
        self.emit("ORL A,R0")
        self.emit("ANL A,#1Fh")
        self.emit("MOVX @DPTR,A")
        self.emit("INC DPTR")
        self.emit("MOV A,R2")
        self.emit("ANL A,#0Fh")
        self.emit("MOVX @DPTR,A")
        self.emit(f"MOV DPTR,#{PSEG_SYMBOL}")
        self.emit(f"LCALL {firmware_symbol('SendPrm')}")
        self.emit(f"MOV DPTR,#{PSEG_SYMBOL}")
        self.emit("MOVX A,@DPTR")
        self.emit("JNZ ?PARAM1")
        self.emit("INC DPTR")
        self.emit("MOVX A,@DPTR")
        self.emit("ANL A,#0Fh")
        self.emit("ORL A,#80h")
        self.emit("SJMP ?PARAM2")
        self.label("?PARAM1")
        self.emit("CLR A")
        self.label("?PARAM2")
        self.emit("MOV R0,A")
        flag = self.pmap.flag(PARAM_FLAG)
        self.load_acc(flag)
        self.emit("ANL A,#70h")
        self.emit("ORL A,R0")
        self.store_acc(flag)
        self.emit("SETB C")
        self.emit("RET")
