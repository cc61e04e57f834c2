"""An MCS-51 (8051) emulator fast enough to run AS-i master firmware in pure Python.

Every instruction's behaviour is written once, as Python source templates in
``_Writer``. The templates are turned into code two ways:

* **Handlers** (the interpreter): one function per opcode, fetching its operand bytes
  and the register bank at run time. Single-stepping and tracing use these.
* **Blocks** (the translator): straight-line code from a start address up to the next
  jump, call, return or register-bank switch, compiled into one Python function with
  every operand folded to a constant, register-bank addresses resolved, and ACC and
  PSW held in local variables. Blocks are cached per (address, register bank).

Both paths come from the same templates, so they cannot disagree about what an
instruction does; tests still compare them on random programs. Lengths and cycle
counts come from the shared instruction table (:mod:`asictl.mcs51.isa`), which the
assembler and disassembler use too.

Three invariants the generated code relies on:

* During a run, bit 0 of ``sfr[PSW]`` (the parity flag) is kept 0 and parity is
  computed from ACC when PSW is read; :meth:`Emulator.run` stores the true parity when
  it returns, and the ``psw`` property always computes it. Generated code keeps the
  carry apart from the rest of PSW, in a local of its own (0 or 1): bit logic, which
  is most of a PLC program, then works on a plain local.
* A block never contains a breakpoint, trap or ``until`` address except as its first
  instruction, so stopping is only ever decided between blocks.
* A block never changes the register bank except in its last instruction, so register
  addresses inside it are constants.
"""

from __future__ import annotations

import enum
import functools
import re
from collections.abc import Callable
from types import CodeType
from typing import Any

from asictl.errors import ExitCode, UserError
from asictl.mcs51.bus import Bus, CodeMemory
from asictl.mcs51.isa import OPCODES, UNDEFINED_OPCODE, OpcodeInfo, Operand

# SFR addresses the core itself uses.
ACC, B, PSW = 0xE0, 0xF0, 0xD0
SP, DPL, DPH = 0x81, 0x82, 0x83
PORTS = (0x80, 0x90, 0xA0, 0xB0)  # P0-P3

#: Parity of every byte value: 1 if it has an odd number of one bits.
PARITY = bytes(bin(v).count("1") & 1 for v in range(256))

#: Longest block, in instructions. Longer blocks save dispatches but a run whose
#: remaining budget is smaller than the block finishes in the interpreter.
MAX_BLOCK = 48

_CYCLES = tuple(info.cycles if info else 0 for info in OPCODES)
_REGISTER_NUMBER = {Operand[f"R{n}"]: n for n in range(8)}
_INDIRECT = {Operand.AT_R0: 0, Operand.AT_R1: 1}
# What the semantic methods of _Writer get: operand kinds, and per operand its value as a
# constant (in a block) or as the name of a local (in a handler); None for A, R0, ...
Operands = tuple[Operand, ...]
Values = list[int | str | None]


def _encoded(value: int | str | None) -> int | str:
    """The value of an operand the opcode encodes in bytes (address, bit, target, data)."""
    assert value is not None, "operands without bytes (A, C, R0, ...) have no value"
    return value


class EmulatorError(UserError):
    """The emulated program did something the 8051 does not define."""

    exit_code = ExitCode.FAILED


class UndefinedOpcode(EmulatorError):
    """The program fetched A5h, the one opcode the MCS-51 leaves undefined."""

    def __init__(self, pc: int) -> None:
        self.pc = pc
        self.opcode = UNDEFINED_OPCODE
        super().__init__(f"undefined opcode {UNDEFINED_OPCODE:02X}h at {pc:04X}h")


class StopReason(enum.Enum):
    """Why :meth:`Emulator.run` returned."""

    INSTRUCTIONS = "instruction budget exhausted"
    CYCLES = "cycle budget exhausted"
    BREAKPOINT = "breakpoint"
    UNTIL = "until address reached"
    TRAP = "stopped by trap"


#: A firmware service written in Python, called when the PC reaches its address, before
#: the instruction there executes. It may change any state; if it moves the PC (for
#: example with :meth:`Emulator.ret`) execution continues there, otherwise the
#: instruction at the trap address runs. Returning a true value stops the run.
Trap = Callable[["Emulator"], object]


class _Writer:
    """Writes the Python source of instructions, for a block or for an opcode handler.

    In a block (``static``) operand bytes, the register bank and the addresses of the
    instruction and its successor are known; in a handler they are read at run time. The
    semantic methods (``_add``, ``_mov``, ...) are shared and see only expressions.

    The generated code uses the locals ``a`` for ACC, ``c`` for the carry (0 or 1) and
    ``psw`` for the rest of PSW (without carry and parity bits); every assignment to
    them starts a line with ``a = ``, ``c = `` or ``psw = ``, which ``finish`` relies on
    to decide what to load and store.
    """

    def __init__(self, *, static: bool, bank: int = 0) -> None:
        self.static = static
        self.base = bank  # register bank base address (0, 8, 16, 24) in a block
        # Lines of code, and exits: (depth, target) where the block or handler ends.
        self.lines: list[str | tuple[int, int | str]] = []
        self.depth = 1
        self.bank_changes = False  # a block's last instruction may have switched banks
        self.ended = False  # the instruction transfers control; the block ends with it
        self.falls_through = True  # ... unless it is unconditional
        self.here: int | str = "pc"  # address of the instruction being written
        self.next: int | str = "np"  # address of the one after it
        self._temps = 0

    # -- output ---------------------------------------------------------------------

    def emit(self, line: str) -> None:
        self.lines.append("    " * self.depth + line)

    def temp(self, expr: str) -> str:
        """Evaluate ``expr`` once into a fresh local and return its name."""
        name = f"t{self._temps}"
        self._temps += 1
        self.emit(f"{name} = {expr}")
        return name

    def exit(self, target: int | str) -> None:
        self.lines.append((self.depth, target))

    # -- operand access -------------------------------------------------------------

    def reg(self, n: int) -> str:
        return f"iram[{self.base + n}]" if self.static else f"iram[(psw & 24) + {n}]"

    def direct(self, d: int | str, *, rmw: bool = False) -> str:
        """Read a direct address: RAM below 80h, an SFR above.

        Port reads see the pins (latch AND external input) unless ``rmw``: the
        read-modify-write instructions read the latch, as on the real chip.
        """
        if isinstance(d, int):
            if d < 0x80:
                return f"iram[{d}]"
            if d == ACC:
                return "a"
            if d == PSW:
                return "(psw | c << 7 | PAR[a])"
            if d in PORTS and not rmw:
                return f"(sfr[{d}] & pins[{PORTS.index(d)}])"
            return f"sfr[{d}]"
        port = "" if rmw else f"sfr[{d}] & pins[{d} >> 4 & 3] if {d} & 207 == 128 else "
        return (
            f"(iram[{d}] if {d} < 128 else a if {d} == 224 else "
            f"(psw | c << 7 | PAR[a]) if {d} == 208 else {port}sfr[{d}])"
        )

    def set_direct(self, d: int | str, value: str, *, bits: int = 0xFF) -> None:
        """Write a direct address; ``bits`` says which bits may change (for PSW)."""
        if isinstance(d, int):
            if d < 0x80:
                self.emit(f"iram[{d}] = {value}")
            elif d == ACC:
                self.emit(f"a = {value}")
            elif d == PSW:
                value = self.temp(value)
                self.emit(f"c = {value} >> 7")
                self.emit(f"psw = {value} & 126")
                self.bank_changes |= bool(bits & 0x18)
            else:
                self.emit(f"sfr[{d}] = {value}")
            return
        value = self.temp(value)
        for test, stores in (
            (f"if {d} < 128:", [f"iram[{d}] = {value}"]),
            (f"elif {d} == 224:", [f"a = {value}"]),
            (f"elif {d} == 208:", [f"c = {value} >> 7", f"psw = {value} & 126"]),
            ("else:", [f"sfr[{d}] = {value}"]),
        ):
            self.emit(test)
            self.depth += 1
            for store in stores:
                self.emit(store)
            self.depth -= 1

    def bit_place(self, b: int | str) -> tuple[int | str, int | str]:
        """The byte address and bit number of bit address ``b``."""
        if isinstance(b, int):
            return (0x20 + (b >> 3) if b < 0x80 else b & 0xF8), b & 7
        return self.temp(f"({b} >> 3) + 32 if {b} < 128 else {b} & 248"), self.temp(f"{b} & 7")

    def bit(self, b: int | str) -> str:
        """The value (0 or 1) of bit address ``b``."""
        byte, n = self.bit_place(b)
        if byte == PSW and isinstance(n, int):
            return "c" if n == 7 else "PAR[a]" if n == 0 else f"(psw >> {n} & 1)"
        return f"({self.direct(byte)} >> {n} & 1)"

    def bit_test(self, b: int | str, *, rmw: bool = False) -> str:
        """An expression that is true when bit ``b`` is set (cheaper than its value)."""
        byte, n = self.bit_place(b)
        if isinstance(byte, int) and isinstance(n, int):
            if byte == PSW:
                return self.bit(b)
            return f"{self.direct(byte, rmw=rmw)} & {1 << n}"
        return f"{self.direct(byte, rmw=rmw)} >> {n} & 1"

    def update_bit(self, b: int | str, op: str, value: str = "") -> None:
        """Read-modify-write one bit: ``op`` is 'set', 'clear', 'toggle' or 'assign'."""
        byte, n = self.bit_place(b)
        if isinstance(byte, int) and isinstance(n, int) and byte != ACC:
            self._update_known_bit(byte, n, op, value)
            return
        old = self.direct(byte, rmw=True)
        mask = f"{1 << n}" if isinstance(n, int) else f"(1 << {n})"
        new = {
            "set": f"{old} | {mask}",
            "clear": f"{old} & (255 ^ {mask})",
            "toggle": f"{old} ^ {mask}",
            "assign": f"{old} & (255 ^ {mask}) | {value} << {n}",
        }[op]
        self.set_direct(byte, new, bits=1 << n if isinstance(n, int) else 0xFF)

    def _update_known_bit(self, byte: int, n: int, op: str, value: str) -> None:
        """``update_bit`` of a bit whose address a block knows: in place, no shifts."""
        mask = 1 << n
        if byte == PSW:
            if n == 7:
                self.emit({"set": "c = 1", "clear": "c = 0", "toggle": "c = c ^ 1",
                           "assign": f"c = {value}"}[op])
            elif n != 0:  # the parity bit is computed, never stored
                self.emit({"set": f"psw = psw | {mask}", "clear": f"psw = psw & {255 ^ mask}",
                           "toggle": f"psw = psw ^ {mask}",
                           "assign": f"psw = psw & {255 ^ mask} | {value} << {n}"}[op])
                self.bank_changes |= bool(mask & 0x18)
            return
        place = f"iram[{byte}]" if byte < 0x80 else f"sfr[{byte}]"
        if op == "assign":
            self.emit(f"if {value}:")
            self.emit(f"    {place} |= {mask}")
            self.emit("else:")
            self.emit(f"    {place} &= {255 ^ mask}")
        else:
            self.emit({"set": f"{place} |= {mask}", "clear": f"{place} &= {255 ^ mask}",
                       "toggle": f"{place} ^= {mask}"}[op])

    def get(self, kind: Operand, value: int | str | None, *, rmw: bool = False) -> str:
        if kind is Operand.A:
            return "a"
        if kind is Operand.C:
            return "c"
        if kind in _REGISTER_NUMBER:
            return self.reg(_REGISTER_NUMBER[kind])
        if kind in _INDIRECT:
            return f"iram[{self.reg(_INDIRECT[kind])}]"
        if kind is Operand.DIRECT:
            return self.direct(_encoded(value), rmw=rmw)
        if kind in (Operand.IMM, Operand.IMM16):
            return str(value)
        if kind is Operand.BIT:
            return self.bit(_encoded(value))
        if kind is Operand.NBIT:
            return f"(1 ^ {self.bit(_encoded(value))})"
        raise AssertionError(f"no value for operand {kind}")

    def put(self, kind: Operand, value: int | str | None, expr: str) -> None:
        if kind is Operand.A:
            self.emit(f"a = {expr}")
        elif kind is Operand.C:
            self.emit(f"c = {expr}")
        elif kind in _REGISTER_NUMBER:
            self.emit(f"{self.reg(_REGISTER_NUMBER[kind])} = {expr}")
        elif kind in _INDIRECT:
            self.emit(f"iram[{self.reg(_INDIRECT[kind])}] = {expr}")
        elif kind is Operand.DIRECT:
            self.set_direct(_encoded(value), expr)
        elif kind is Operand.BIT:
            self.update_bit(_encoded(value), "assign", expr)
        else:
            raise AssertionError(f"cannot write operand {kind}")

    # -- one instruction ------------------------------------------------------------

    def instruction(self, info: OpcodeInfo, address: int | None, raw: bytes | None) -> None:
        """Emit one instruction; ``address`` and ``raw`` are None in a handler."""
        self._temps = 0
        if self.static:
            assert address is not None and raw is not None
            self.here = address
            self.next = (address + info.length) & 0xFFFF

            def byte(k: int) -> int | str:
                return raw[k]
        else:
            self.here = "pc"
            self.next = "np"
            self.emit(f"np = pc + {info.length} & 65535")

            def byte(k: int) -> int | str:
                name = f"o{k}"
                self.emit(f"{name} = code[pc + {k} & 65535]")
                return name

        values: list[int | str | None] = [None] * len(info.operands)
        offset = 1
        for index in info.encoding:
            kind = info.operands[index]
            if kind is Operand.IMM16 or kind is Operand.ADDR16:
                hi, lo = byte(offset), byte(offset + 1)
                values[index] = (
                    hi << 8 | lo
                    if isinstance(hi, int) and isinstance(lo, int)
                    else f"({hi} << 8 | {lo})"
                )
            elif kind is Operand.REL:
                rel = byte(offset)
                values[index] = (
                    (self.next + (rel ^ 0x80) - 0x80) & 0xFFFF
                    if isinstance(self.next, int) and isinstance(rel, int)
                    else f"np + ({rel} ^ 128) - 128 & 65535"
                )
            elif kind is Operand.ADDR11:
                page = (info.opcode >> 5) << 8
                low = byte(offset)
                values[index] = (
                    (self.next & 0xF800) | page | low
                    if isinstance(self.next, int) and isinstance(low, int)
                    else f"np & 63488 | {page} | {low}"
                )
            else:
                values[index] = byte(offset)
            offset += kind.size
        getattr(self, "_" + info.mnemonic.lower())(info.operands, values)

    # -- control flow helpers -------------------------------------------------------

    def jump(self, target: int | str) -> None:
        self.exit(target)
        self.ended = True
        self.falls_through = False

    def branch(self, condition: str, target: int | str) -> None:
        self.emit(f"if {condition}:")
        self.depth += 1
        self.exit(target)
        self.depth -= 1
        self.ended = True

    def push(self, expr: str) -> None:
        self.emit("t = sfr[129] + 1 & 255")
        self.emit("sfr[129] = t")
        self.emit(f"iram[t] = {expr}")

    def dptr(self) -> str:
        return "(sfr[131] << 8 | sfr[130])"

    def call_device(self, call: str) -> None:
        """Call a bus device with the CPU state it may inspect brought up to date."""
        self.emit("sfr[224] = a")
        self.emit("sfr[208] = psw | c << 7")
        if self.static:
            self.emit(f"emu.pc = {self.here}")
        self.emit(call)

    # -- the instruction set (one method per mnemonic) ------------------------------

    def _nop(self, ops: Operands, vals: Values) -> None:
        pass

    def _arith(self, ops: Operands, vals: Values, carry: bool, subtract: bool) -> None:
        source = self.get(ops[1], vals[1])
        if source.isdigit():  # an immediate in a block: fold what can be folded
            v, low = source, str(int(source) & 15)
        else:
            v = self.temp(source)
            low = f"({v} & 15)"
        c = f" {'-' if subtract else '+'} c" if carry else ""
        if subtract:
            self.emit(f"t = a - {v}{c}")
            self.emit(
                f"psw = psw & 59 | ((a & 15) - {low}{c}) << 2 & 64"
                f" | ((a ^ {v}) & (a ^ t)) >> 5 & 4"
            )
            self.emit("c = t >> 8 & 1")  # a borrow makes t negative
        else:
            self.emit(f"t = a + {v}{c}")
            self.emit(
                f"psw = psw & 59 | ((a & 15) + {low}{c}) << 2 & 64"
                f" | ((a ^ t) & ({v} ^ t)) >> 5 & 4"
            )
            self.emit("c = t >> 8")
        self.emit("a = t & 255")

    def _add(self, ops: Operands, vals: Values) -> None:
        self._arith(ops, vals, carry=False, subtract=False)

    def _addc(self, ops: Operands, vals: Values) -> None:
        self._arith(ops, vals, carry=True, subtract=False)

    def _subb(self, ops: Operands, vals: Values) -> None:
        self._arith(ops, vals, carry=True, subtract=True)

    def _logic(self, ops: Operands, vals: Values, op: str) -> None:
        dst, src = ops
        if dst is Operand.C:
            test = self.bit_test(_encoded(vals[1]))
            if (op == "&") == (src is Operand.NBIT):  # ANL C,/bit and ORL C,bit
                self.emit(f"if {test}:")
            else:
                self.emit(f"if not {test}:")
            self.emit(f"    c = {0 if op == '&' else 1}")
            return
        source = self.get(src, vals[1])
        self.put(dst, vals[0], f"{self.get(dst, vals[0], rmw=True)} {op} {source}")

    def _anl(self, ops: Operands, vals: Values) -> None:
        self._logic(ops, vals, "&")

    def _orl(self, ops: Operands, vals: Values) -> None:
        self._logic(ops, vals, "|")

    def _xrl(self, ops: Operands, vals: Values) -> None:
        self._logic(ops, vals, "^")

    def _inc(self, ops: Operands, vals: Values) -> None:
        if ops[0] is Operand.DPTR:
            self.emit("t = sfr[130] + 1")
            self.emit("if t == 256:")
            self.emit("    sfr[130] = 0")
            self.emit("    sfr[131] = sfr[131] + 1 & 255")
            self.emit("else:")
            self.emit("    sfr[130] = t")
            return
        self.put(ops[0], vals[0], f"{self.get(ops[0], vals[0], rmw=True)} + 1 & 255")

    def _dec(self, ops: Operands, vals: Values) -> None:
        self.put(ops[0], vals[0], f"{self.get(ops[0], vals[0], rmw=True)} - 1 & 255")

    def _mov(self, ops: Operands, vals: Values) -> None:
        dst, src = ops
        if dst is Operand.DPTR:
            imm = vals[1]
            if isinstance(imm, int):
                self.emit(f"sfr[131] = {imm >> 8}")
                self.emit(f"sfr[130] = {imm & 0xFF}")
            else:
                self.emit(f"sfr[131] = {imm} >> 8")
                self.emit(f"sfr[130] = {imm} & 255")
            return
        if dst is Operand.C and self.static:  # MOV C,bit: the commonest PLC instruction
            self.emit(f"c = 1 if {self.bit_test(_encoded(vals[1]))} else 0")
            return
        self.put(dst, vals[0], self.get(src, vals[1]))

    def _movc(self, ops: Operands, vals: Values) -> None:
        base = self.next if ops[1] is Operand.AT_A_PC else self.dptr()
        self.emit(f"a = code[a + {base} & 65535]")

    def _movx_address(self, operand: Operand) -> str:
        if operand is Operand.AT_DPTR:
            return self.temp(self.dptr())
        return self.temp(f"sfr[160] << 8 | {self.reg(_INDIRECT[operand])}")

    def _movx(self, ops: Operands, vals: Values) -> None:
        if ops[0] is Operand.A:
            address = self._movx_address(ops[1])
            self.emit(f"h = xrd[{address}]")
            self.emit("if h is None:")
            self.emit(f"    a = xram[{address}]")
            self.emit("else:")
            self.depth += 1
            self.call_device(f"a = h({address}) & 255")
            self.depth -= 1
        else:
            address = self._movx_address(ops[0])
            self.emit(f"h = xwr[{address}]")
            self.emit("if h is None:")
            self.emit(f"    xram[{address}] = a")
            self.emit("else:")
            self.depth += 1
            self.call_device(f"h({address}, a)")
            self.depth -= 1

    def _clr(self, ops: Operands, vals: Values) -> None:
        if ops[0] is Operand.A:
            self.emit("a = 0")
        elif ops[0] is Operand.C:
            self.emit("c = 0")
        else:
            self.update_bit(_encoded(vals[0]), "clear")

    def _setb(self, ops: Operands, vals: Values) -> None:
        if ops[0] is Operand.C:
            self.emit("c = 1")
        else:
            self.update_bit(_encoded(vals[0]), "set")

    def _cpl(self, ops: Operands, vals: Values) -> None:
        if ops[0] is Operand.A:
            self.emit("a = a ^ 255")
        elif ops[0] is Operand.C:
            self.emit("c = c ^ 1")
        else:
            self.update_bit(_encoded(vals[0]), "toggle")

    def _rl(self, ops: Operands, vals: Values) -> None:
        self.emit("a = (a << 1 | a >> 7) & 255")

    def _rr(self, ops: Operands, vals: Values) -> None:
        self.emit("a = (a >> 1 | a << 7) & 255")

    def _rlc(self, ops: Operands, vals: Values) -> None:
        self.emit("t = a << 1 | c")
        self.emit("c = t >> 8")
        self.emit("a = t & 255")

    def _rrc(self, ops: Operands, vals: Values) -> None:
        self.emit("t = a | c << 8")
        self.emit("c = a & 1")
        self.emit("a = t >> 1")

    def _swap(self, ops: Operands, vals: Values) -> None:
        self.emit("a = (a << 4 | a >> 4) & 255")

    def _da(self, ops: Operands, vals: Values) -> None:
        # Intel's rule: each nibble correction can set CY but never clears it.
        self.emit("t = a")
        self.emit("if t & 15 > 9 or psw & 64:")
        self.emit("    t = t + 6")
        self.emit("if t > 255 or c or t & 240 > 144:")
        self.emit("    t = t + 96")
        self.emit("if t > 255:")
        self.emit("    c = 1")
        self.emit("a = t & 255")

    def _mul(self, ops: Operands, vals: Values) -> None:
        self.emit("t = a * sfr[240]")
        self.emit("sfr[240] = t >> 8")
        self.emit("a = t & 255")
        self.emit("c = 0")
        self.emit("psw = psw & 251 | (4 if t > 255 else 0)")

    def _div(self, ops: Operands, vals: Values) -> None:
        self.emit("t = sfr[240]")
        self.emit("c = 0")
        self.emit("if t:")
        self.emit("    sfr[240] = a % t")
        self.emit("    a = a // t")
        self.emit("    psw = psw & 251")
        self.emit("else:")
        self.emit("    psw = psw | 4")

    def _xch(self, ops: Operands, vals: Values) -> None:
        old = self.temp(self.get(ops[1], vals[1]))
        self.put(ops[1], vals[1], "a")
        self.emit(f"a = {old}")

    def _xchd(self, ops: Operands, vals: Values) -> None:
        place = self.temp(self.reg(_INDIRECT[ops[1]]))
        self.emit(f"t = iram[{place}]")
        self.emit(f"iram[{place}] = t & 240 | a & 15")
        self.emit("a = a & 240 | t & 15")

    def _push(self, ops: Operands, vals: Values) -> None:
        self.push(self.get(ops[0], vals[0]))

    def _pop(self, ops: Operands, vals: Values) -> None:
        self.emit("t = sfr[129]")
        value = self.temp("iram[t]")
        self.emit("sfr[129] = t - 1 & 255")
        self.put(ops[0], vals[0], value)

    def _ajmp(self, ops: Operands, vals: Values) -> None:
        self.jump(_encoded(vals[0]))

    _ljmp = _sjmp = _ajmp

    def _jmp(self, ops: Operands, vals: Values) -> None:
        self.jump(self.temp(f"a + {self.dptr()} & 65535"))

    def _acall(self, ops: Operands, vals: Values) -> None:
        ret = self.next
        if isinstance(ret, int):  # in a block
            self.push(str(ret & 0xFF))
            self.push(str(ret >> 8))
        else:
            self.push("np & 255")
            self.push("np >> 8")
        self.jump(_encoded(vals[0]))

    _lcall = _acall

    def _ret(self, ops: Operands, vals: Values) -> None:
        self.emit("t = sfr[129]")
        self.emit("sfr[129] = t - 2 & 255")
        self.jump(self.temp("iram[t] << 8 | iram[t - 1 & 255]"))

    _reti = _ret

    def _jc(self, ops: Operands, vals: Values) -> None:
        self.branch("c", _encoded(vals[0]))

    def _jnc(self, ops: Operands, vals: Values) -> None:
        self.branch("not c", _encoded(vals[0]))

    def _jz(self, ops: Operands, vals: Values) -> None:
        self.branch("not a", _encoded(vals[0]))

    def _jnz(self, ops: Operands, vals: Values) -> None:
        self.branch("a", _encoded(vals[0]))

    def _jb(self, ops: Operands, vals: Values) -> None:
        self.branch(self.bit_test(_encoded(vals[0])), _encoded(vals[1]))

    def _jnb(self, ops: Operands, vals: Values) -> None:
        self.branch(f"not {self.bit_test(_encoded(vals[0]))}", _encoded(vals[1]))

    def _jbc(self, ops: Operands, vals: Values) -> None:
        # JBC reads the latch (it is read-modify-write) and clears the bit if it jumps.
        bit = _encoded(vals[0])
        self.emit(f"if {self.bit_test(bit, rmw=True)}:")
        self.depth += 1
        self.update_bit(bit, "clear")
        self.exit(_encoded(vals[1]))
        self.depth -= 1
        self.ended = True

    def _cjne(self, ops: Operands, vals: Values) -> None:
        left = self.temp(self.get(ops[0], vals[0]))
        right = self.temp(self.get(ops[1], vals[1]))
        self.emit(f"c = 1 if {left} < {right} else 0")
        self.branch(f"{left} != {right}", _encoded(vals[2]))

    def _djnz(self, ops: Operands, vals: Values) -> None:
        value = self.temp(f"{self.get(ops[0], vals[0], rmw=True)} - 1 & 255")
        self.put(ops[0], vals[0], value)
        self.branch(value, _encoded(vals[1]))

    # -- assembling the function ----------------------------------------------------

    def finish(
        self, name: str, fallthrough: int | str | None, loop_start: int | None = None
    ) -> str:
        """The complete ``def`` with loads, stores and exits filled in.

        With ``loop_start`` (a block that branches back to its own first instruction), the
        body becomes a loop run up to ``k`` times, the count the budget allows; the
        iterations done are left in ``iterations[0]``. The branch back then costs no
        function call and no dispatch, which is what polling and delay loops need.
        """
        if fallthrough is not None:
            self.exit(fallthrough)
        text = "\n".join(line for line in self.lines if isinstance(line, str))
        stores = []
        if re.search(r"^\s*a = ", text, re.M):
            stores.append("sfr[224] = a")
        uses_psw = bool(re.search(r"\bpsw\b", text)) or (self.static and self.bank_changes)
        uses_c = bool(re.search(r"\bc\b", text))
        if re.search(r"^\s*(psw|c) = ", text, re.M):
            merged = "psw" if uses_psw else "sfr[208] & 127"
            stores.append(f"sfr[208] = {merged} | c << 7")
        if loop_start is not None:
            stores.append("iterations[0] = i")
        signature = "pc" if not self.static else "k" if loop_start is not None else ""
        out = [f"    def {name}({signature}):"]
        if re.search(r"\ba\b", text):
            out.append("        a = sfr[224]")
        if uses_psw:
            out += ["        psw = sfr[208]", "        c = psw >> 7", "        psw = psw & 127"]
        elif uses_c:
            out.append("        c = sfr[208] >> 7")
        indent = "    "
        if loop_start is not None:
            out += ["        i = 1", "        while True:"]
            indent = "        "
        for line in self.lines:
            if isinstance(line, str):
                out.append(indent + line)
                continue
            depth, target = line
            pad = indent + "    " * depth
            if target == loop_start:
                out += [pad + "if i < k:", pad + "    i += 1", pad + "    continue"]
            out.extend(pad + store for store in stores)
            out.append(pad + f"return {self._key(target)}")
        return "\n".join(out)

    def loops_to(self, start: int) -> bool:
        """True if this block can branch back to ``start`` in the same register bank."""
        return not self.bank_changes and any(
            not isinstance(line, str) and line[1] == start for line in self.lines
        )

    def _key(self, target: int | str) -> str:
        """A block returns its successor's cache key: address plus register bank bits."""
        if not self.static:
            return str(target)
        if self.bank_changes:
            return f"{target} | (psw & 24) << 13"
        if isinstance(target, int):
            return str(target | self.base << 13)
        return f"{target} | {self.base << 13}"


_FACTORY_HEADER = "def factory(iram, sfr, code, xram, xrd, xwr, pins, emu, iterations):\n"


@functools.lru_cache(maxsize=8192)
def _compile(source: str) -> CodeType:
    """Compile generated source once per process; emulators share the code objects."""
    return compile(source, "<mcs51-translation>", "exec")


def _instantiate(source: str, emu: Emulator) -> Any:
    """What the generated ``factory`` returns: the handlers' tuple, or a block function."""
    namespace: dict[str, Any] = {"PAR": PARITY}
    exec(_compile(source), namespace)
    bus = emu.xdata
    return namespace["factory"](
        emu.iram,
        emu.sfr,
        emu.code,
        bus.ram,
        bus.readers,
        bus.writers,
        emu.pins,
        emu,
        emu._iterations,
    )


def _handler_source() -> str:
    """One interpreter handler per defined opcode, returned as a 256-entry tuple."""
    parts = [_FACTORY_HEADER]
    names = []
    for info in OPCODES:
        if info is None:
            names.append("None")
            continue
        writer = _Writer(static=False)
        writer.instruction(info, None, None)
        name = f"op_{info.opcode:02x}"
        parts.append(writer.finish(name, "np" if writer.falls_through else None) + "\n")
        names.append(name)
    parts.append(f"    return ({', '.join(names)},)\n")
    return "".join(parts)


_HANDLERS = _handler_source()


def _undefined_block(pc: int) -> Callable[[], int]:
    def undefined() -> int:
        raise UndefinedOpcode(pc)

    return undefined


#: A translation cache entry: the block function (None to hand control back to the run
#: loop: a stop address or trap), its instructions and machine cycles, and whether it is a
#: self-loop (called with the iterations the budget allows, see ``_Writer.finish``).
Entry = tuple[Callable[..., int] | None, int, int, bool]
_STOP_ENTRY: Entry = (None, 0, 0, False)
_UNLIMITED = 1 << 62


class Emulator:
    """One 8051 core: registers, internal RAM, SFRs, code memory and an XDATA bus.

    State is plain data meant to be read and written directly: ``iram`` (256 bytes),
    ``sfr`` (256 bytes indexed by SFR address; 80h-FFh are used), ``code``, ``xdata``,
    ``pins`` (the external input on P0-P3, default FFh: unconnected pins read high),
    ``pc`` and the counters ``instructions`` and ``cycles`` (machine cycles).

    ``translate=False`` runs everything in the interpreter, which is slower but updates
    state one instruction at a time (for device callbacks that need exact counters).
    """

    def __init__(self, *, xdata: Bus | None = None, translate: bool = True) -> None:
        self.code = CodeMemory()
        self.code.on_write = self._invalidate
        self.xdata = xdata if xdata is not None else Bus()
        self.iram = bytearray(256)
        self.sfr = bytearray(256)
        self.pins = bytearray(b"\xff" * 4)
        self.translate = translate
        self.pc = 0
        self.instructions = 0
        self.cycles = 0
        self._breakpoints: set[int] = set()
        self._traps: dict[int, Trap] = {}
        self._blocks: dict[int, Entry] = {}
        self._iterations = [0]  # how often the last self-looping block went round
        self._stops: frozenset[int] = frozenset()
        self._handlers: tuple[Callable[[int], int] | None, ...] = _instantiate(_HANDLERS, self)
        self.reset()

    # -- state ----------------------------------------------------------------------

    def reset(self) -> None:
        """Hardware reset: SFRs to their reset values, PC and counters to 0.

        Internal RAM and XDATA keep their contents, as on the chip.
        """
        self.sfr[:] = bytes(256)
        for port in PORTS:
            self.sfr[port] = 0xFF
        self.sfr[SP] = 0x07
        self.pc = 0
        self.instructions = 0
        self.cycles = 0

    @property
    def a(self) -> int:
        return self.sfr[ACC]

    @a.setter
    def a(self, value: int) -> None:
        self.sfr[ACC] = value
        self.sfr[PSW] = self.sfr[PSW] & 0xFE | PARITY[value]

    @property
    def b(self) -> int:
        return self.sfr[B]

    @b.setter
    def b(self, value: int) -> None:
        self.sfr[B] = value

    @property
    def psw(self) -> int:
        """PSW with the parity flag computed from ACC, as the hardware keeps it."""
        return self.sfr[PSW] & 0xFE | PARITY[self.sfr[ACC]]

    @psw.setter
    def psw(self, value: int) -> None:
        self.sfr[PSW] = value & 0xFE | PARITY[self.sfr[ACC]]

    @property
    def sp(self) -> int:
        return self.sfr[SP]

    @sp.setter
    def sp(self, value: int) -> None:
        self.sfr[SP] = value

    @property
    def dptr(self) -> int:
        return self.sfr[DPH] << 8 | self.sfr[DPL]

    @dptr.setter
    def dptr(self, value: int) -> None:
        self.sfr[DPH], self.sfr[DPL] = value >> 8 & 0xFF, value & 0xFF

    @property
    def bank(self) -> int:
        """The register bank PSW.RS1/RS0 selects (0-3)."""
        return self.sfr[PSW] >> 3 & 3

    def r(self, n: int) -> int:
        """Register Rn of the active bank."""
        return self.iram[self.bank * 8 + n]

    def set_r(self, n: int, value: int) -> None:
        self.iram[self.bank * 8 + n] = value

    # -- helpers for traps ----------------------------------------------------------

    def push(self, value: int) -> None:
        """Push a byte as PUSH does (SP is incremented first)."""
        self.sfr[SP] = (self.sfr[SP] + 1) & 0xFF
        self.iram[self.sfr[SP]] = value

    def pop(self) -> int:
        value = self.iram[self.sfr[SP]]
        self.sfr[SP] = (self.sfr[SP] - 1) & 0xFF
        return value

    def ret(self) -> None:
        """Return to the caller as RET does, so a trap can stand in for a subroutine."""
        high = self.pop()
        self.pc = high << 8 | self.pop()

    # -- breakpoints and traps ------------------------------------------------------

    @property
    def breakpoints(self) -> frozenset[int]:
        return frozenset(self._breakpoints)

    def add_breakpoint(self, address: int) -> None:
        """Stop a run before the instruction at ``address`` (not the run's first one)."""
        self._breakpoints.add(address & 0xFFFF)

    def remove_breakpoint(self, address: int) -> None:
        self._breakpoints.discard(address & 0xFFFF)

    @property
    def traps(self) -> dict[int, Trap]:
        return dict(self._traps)

    def add_trap(self, address: int, trap: Trap) -> None:
        """Call ``trap(emulator)`` whenever the PC reaches ``address`` (see ``Trap``)."""
        self._traps[address & 0xFFFF] = trap

    def remove_trap(self, address: int) -> None:
        self._traps.pop(address & 0xFFFF, None)

    # -- execution ------------------------------------------------------------------

    def step(self) -> StopReason:
        """Execute one instruction (after any trap at the PC has run)."""
        return self.run(max_instructions=1)

    def run(
        self,
        max_instructions: int | None = None,
        max_cycles: int | None = None,
        until: int | None = None,
        trace: Callable[[Emulator, int], None] | None = None,
    ) -> StopReason:
        """Run until a budget is used up, a breakpoint or ``until`` is reached, or a trap
        asks to stop.

        Breakpoints and ``until`` stop *before* the instruction at their address, and are
        not checked for the first instruction of a run, so calling ``run`` again resumes.
        The cycle budget lets the last instruction finish: a run stops once at least
        ``max_cycles`` machine cycles have elapsed. ``trace(emulator, address)`` is called
        after every instruction and forces the interpreter.

        Raises :class:`UndefinedOpcode` with the PC at the A5h byte.
        """
        ilimit = _UNLIMITED if max_instructions is None else self.instructions + max_instructions
        climit = _UNLIMITED if max_cycles is None else self.cycles + max_cycles
        if until is not None:
            until &= 0xFFFF
        self.sfr[PSW] &= 0xFE
        try:
            return self._run(ilimit, climit, until, trace)
        finally:
            self.sfr[PSW] = self.sfr[PSW] & 0xFE | PARITY[self.sfr[ACC]]

    def _stop_addresses(self, until: int | None) -> frozenset[int]:
        stops = frozenset(self._breakpoints | self._traps.keys())
        if until is not None:
            stops |= {until}
        if stops != self._stops:
            self._stops = stops
            self._blocks.clear()
        return stops

    def _run(
        self,
        ilimit: int,
        climit: int,
        until: int | None,
        trace: Callable[[Emulator, int], None] | None,
    ) -> StopReason:
        stops = self._stop_addresses(until)
        first = True
        interpret = trace is not None or not self.translate
        while True:
            pc = self.pc
            if not first and pc in stops and pc not in self._traps:
                return StopReason.UNTIL if pc == until else StopReason.BREAKPOINT
            if self.instructions >= ilimit:
                return StopReason.INSTRUCTIONS
            if self.cycles >= climit:
                return StopReason.CYCLES
            trap = self._traps.get(pc)
            if trap is not None:
                first = False
                if trap(self):
                    return StopReason.TRAP
                self.sfr[PSW] &= 0xFE  # the trap may have set the parity bit
                stops = self._stop_addresses(until)
                if self.pc != pc:
                    continue
            # One instruction is not worth translating a block for (single-stepping).
            if interpret or pc in stops or ilimit - self.instructions == 1:
                first = False
                self._interpret_one()
                if trace is not None:
                    trace(self, pc)
                continue
            first = False
            interpret = self._run_blocks(ilimit, climit)

    def _interpret_one(self) -> None:
        pc = self.pc
        opcode = self.code[pc]
        handler = self._handlers[opcode]
        if handler is None:
            raise UndefinedOpcode(pc)
        self.pc = handler(pc)
        self.instructions += 1
        self.cycles += _CYCLES[opcode]

    def _run_blocks(self, ilimit: int, climit: int) -> bool:
        """Chain translated blocks until one is a stop entry or does not fit the budget.

        Returns True when the budget is nearly spent, so the caller finishes in the
        interpreter instead of translating blocks at every remaining address.
        """
        blocks, iterations = self._blocks, self._iterations
        icount, ccount = self.instructions, self.cycles
        key = self.pc | (self.sfr[PSW] & 24) << 13
        try:
            while True:
                entry = blocks.get(key)
                if entry is None:
                    entry = self._translate(key)
                block, n, cycles, loops = entry
                if block is None:
                    return False
                if loops:
                    allowed = min((ilimit - icount) // n, (climit - ccount) // cycles)
                    if allowed < 1:
                        return True
                    key = block(allowed)
                    icount += n * iterations[0]
                    ccount += cycles * iterations[0]
                    continue
                if icount + n > ilimit or ccount + cycles > climit:
                    return True
                key = block()
                icount += n
                ccount += cycles
        finally:
            self.pc = key & 0xFFFF
            self.instructions, self.cycles = icount, ccount

    def _invalidate(self) -> None:
        self._blocks.clear()

    def _translate(self, key: int) -> Entry:
        pc, bank = key & 0xFFFF, key >> 13 & 24
        code = self.code
        if pc in self._stops:
            entry = _STOP_ENTRY
        elif code[pc] == UNDEFINED_OPCODE:
            entry = (_undefined_block(pc), 1, 0, False)
        else:
            writer = _Writer(static=True, bank=bank)
            address, count, cycles = pc, 0, 0
            while True:
                info = OPCODES[code[address]]
                assert info is not None  # the block ends before an undefined opcode
                raw = bytes(code[(address + k) & 0xFFFF] for k in range(info.length))
                writer.instruction(info, address, raw)
                count += 1
                cycles += info.cycles
                address = (address + info.length) & 0xFFFF
                if (
                    writer.ended
                    or writer.bank_changes
                    or count == MAX_BLOCK
                    or address in self._stops
                    or OPCODES[code[address]] is None
                ):
                    break
            loops = writer.loops_to(pc)
            body = writer.finish(
                "block", address if writer.falls_through else None, pc if loops else None
            )
            source = f"{_FACTORY_HEADER}{body}\n    return block\n"
            block: Callable[..., int] = _instantiate(source, self)
            entry = (block, count, cycles, loops)
        self._blocks[key] = entry
        return entry


__all__ = [
    "PARITY",
    "Emulator",
    "EmulatorError",
    "StopReason",
    "Trap",
    "UndefinedOpcode",
]
