"""The Python source of every 8051 instruction, for the emulator to compile.

Every instruction's behaviour is written once, here, as templates that produce Python
source. The emulator compiles them two ways: as one handler per opcode (operand bytes
and register bank read at run time) and as translated code, where operand bytes, the
register bank and the instruction's address are constants (blocks, and the regions of
:mod:`asictl.mcs51.regions`). Lengths and cycle counts come from the shared instruction
table (:mod:`asictl.mcs51.isa`).
"""

from __future__ import annotations

import re

from asictl.mcs51.isa import OpcodeInfo, Operand

# SFR addresses the core itself uses.
ACC, B, PSW = 0xE0, 0xF0, 0xD0
SP, DPL, DPH = 0x81, 0x82, 0x83
PORTS = (0x80, 0x90, 0xA0, 0xB0)  # P0-P3

#: DPTR read from its two SFRs, into generated code's local ``dp``.
_DPTR_IN_SFRS = "sfr[131] << 8 | sfr[130]"

#: Parity of every byte value: 1 if it has an odd number of one bits.
PARITY = bytes(bin(v).count("1") & 1 for v in range(256))

_REGISTER_NUMBER = {Operand[f"R{n}"]: n for n in range(8)}
_INDIRECT = {Operand.AT_R0: 0, Operand.AT_R1: 1}
# What the semantic methods of Writer get: operand kinds, and per operand its value as a
# constant (in a block) or as the name of a local (in a handler); None for A, R0, ...
Operands = tuple[Operand, ...]
Values = list[int | str | None]


#: Marks around a device call in generated code: comments in blocks and handlers; code
#: that keeps internal RAM bytes in locals (regions) stores them before the call and
#: loads them after it, since a device may look at (or change) any of the machine's state.
FLUSH = "# flush"
RELOAD = "# reload"


def _encoded(value: int | str | None) -> int | str:
    """The value of an operand the opcode encodes in bytes (address, bit, target, data)."""
    assert value is not None, "operands without bytes (A, C, R0, ...) have no value"
    return value


class Writer:
    """Writes the Python source of instructions, for a block or for an opcode handler.

    In a block (``static``) operand bytes, the register bank and the addresses of the
    instruction and its successor are known; in a handler they are read at run time. The
    semantic methods (``_add``, ``_mov``, ...) are shared and see only expressions.

    The generated code uses the locals ``a`` for ACC, ``c`` for the carry (0 or 1) and
    ``psw`` for the rest of PSW (without carry and parity bits), and in a block ``dp``
    for DPTR (a MOVX through it, an ``INC DPTR`` then cost no SFR accesses); every
    assignment to them starts a line with ``a = ``, ``c = ``, ``psw = `` or ``dp = ``,
    which ``finish`` relies on to decide what to load and store.
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
            if d in (DPL, DPH) and self.static:
                return "(dp & 255)" if d == DPL else "(dp >> 8)"
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
            elif d == DPL and self.static:
                self.emit(f"dp = dp & 65280 | ({value})")
            elif d == DPH and self.static:
                self.emit(f"dp = ({value}) << 8 | dp & 255")
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
        return "dp" if self.static else "(sfr[131] << 8 | sfr[130])"

    def call_device(self, call: str) -> None:
        """Call a bus device with the CPU state it may inspect brought up to date."""
        self.emit(FLUSH)
        self.emit("sfr[224] = a")
        self.emit("sfr[208] = psw | c << 7")
        if self.static:
            self.emit("sfr[131] = dp >> 8")
            self.emit("sfr[130] = dp & 255")
            self.emit(f"emu.pc = {self.here}")
        self.emit(call)
        if self.static:
            self.emit(f"dp = {_DPTR_IN_SFRS}")
        self.emit(RELOAD)

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
        if ops[0] is Operand.DPTR and self.static:
            self.emit("dp = dp + 1 & 65535")
            return
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
                self.emit(f"dp = {imm}")
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
            return self.dptr() if self.static else self.temp(self.dptr())
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
        loads, stores = register_locals(text, self.static and self.bank_changes)
        if loop_start is not None:
            stores.append("iterations[0] = i")
        signature = "pc" if not self.static else "k" if loop_start is not None else ""
        out = [f"    def {name}({signature}):"]
        out += ["        " + load for load in loads]
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
        return translation_key(target, self.base, self.bank_changes)


def translation_key(target: int | str, base: int, bank_changes: bool) -> str:
    """Translated code returns its successor's cache key: address plus register bank bits
    (the bank's base address 0, 8, 16 or 24, shifted above the 16 address bits)."""
    if bank_changes:
        return f"{target} | (psw & 24) << 13"
    if isinstance(target, int):
        return str(target | base << 13)
    return f"{target} | {base << 13}"


def register_locals(text: str, bank_changes: bool) -> tuple[list[str], list[str]]:
    """The loads and stores generated ``text`` needs for its locals ``a``, ``c``, ``psw``.

    ``bank_changes``: the code returns a key computed from the register bank bits.
    """
    loads, stores = [], []
    if re.search(r"\ba\b", text):
        loads.append("a = sfr[224]")
    if re.search(r"^\s*a = ", text, re.M):
        stores.append("sfr[224] = a")
    uses_psw = bank_changes or bool(re.search(r"\bpsw\b", text))
    if uses_psw:
        loads += ["psw = sfr[208]", "c = psw >> 7", "psw = psw & 127"]
    elif re.search(r"\bc\b", text):
        loads.append("c = sfr[208] >> 7")
    if re.search(r"^\s*(psw|c) = ", text, re.M):
        stores.append(f"sfr[208] = {'psw' if uses_psw else 'sfr[208] & 127'} | c << 7")
    if re.search(r"\bdp\b", text):
        loads.append(f"dp = {_DPTR_IN_SFRS}")
    if re.search(r"^\s*dp = ", text, re.M):
        stores += ["sfr[131] = dp >> 8", "sfr[130] = dp & 255"]
    return loads, stores
