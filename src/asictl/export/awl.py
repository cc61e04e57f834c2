"""A checked IL program as S7 STL (AWL) for an S7-300/400-style CPU, as awlsim runs it.

Exact before idiomatic (docs/migrate.md). Two rules of the master have no S7 twin and
decide the shape of the code:

* The IL's "first check" is lexical (the start of a block, after ``***``), S7's is
  dynamic (``=``, ``S``, ``R`` and jumps end a logic string, so the next ``A`` loads).
  The IL's single-bit register therefore lives in a bit of DB 1 (``RLO``): a logic
  string runs in S7's RLO as long as it goes on, and is written back with ``= RLO``
  before anything else; an instruction that needs the register when no string is open
  loads it back with ``A RLO``. S7's ``JC`` sets its RLO to 1 when it does not jump;
  the IL keeps 0, which the bit in DB 1 still holds.
* The IL's accumulators, constant register and register keep their values from one
  cycle to the next; S7 clears its own at every OB 1. So ACCU1, ACCU2 and the constant
  register are words of DB 1 too, and S7's accumulators only carry values within one
  translated line.

Timers are words of remaining 10 ms ticks (DB 2), counted down at the start of each
OB 1 by the number of 10 ms steps of SFC 64's millisecond clock since the last cycle
(the remainder carried over, the 31-bit wrap handled), which is the master's tick
exactly when the cycle time is a multiple of 10 ms. Counters are words of DB 3, or
flag bytes 96..125 with map_counters. Function blocks become FCs (they have no data of
their own: the IL shares everything). What only the master can do (its firmware blocks,
PARAM, [ASSEMBLY] lines) is left for a person, marked in the code and listed.

The output is built as objects (``Line``, ``Block``) and printed at the end.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import assert_never

from asictl.export import layout as at
from asictl.export.gaps import Unfinished, gap, host_flags, il_comment, unfinished
from asictl.export.layout import Layout, layout_of
from asictl.il import ast
from asictl.il.ast import key
from asictl.il.language import PARAM_FLAG, TC_MAX_VALUE
from asictl.il.loader import Program
from asictl.il.oracle import Scope, scope_of
from asictl.observe.symbols import SymbolTable

K = ast.OperandKind


@dataclass(frozen=True)
class Line:
    """One AWL line: an instruction with its operand, a label, a comment, or all three."""

    op: str = ""
    operand: str = ""
    label: str = ""
    comment: str = ""

    def render(self) -> str:
        head = f"{self.label}:" if self.label else ""
        text = f"{head:<6}{self.op:<5} {self.operand}".rstrip() if self.op else head
        if self.comment:
            text = f"{text:<32}// {self.comment}" if text else f"      // {self.comment}"
        return text


@dataclass
class Block:
    """One AWL block: an organization block, a function or a data block."""

    kind: str  # ORGANIZATION_BLOCK, FUNCTION, DATA_BLOCK
    name: str  # "OB 1", "FC 2", "DB 1"
    title: str
    lines: list[Line] = field(default_factory=list)
    temp: tuple[str, ...] = ()
    #: a data block's size in bytes
    size: int = 0

    def render(self) -> str:
        head = f"{self.kind} {self.name}" + (" : VOID" if self.kind == "FUNCTION" else "")
        out = [head, f"TITLE = {self.title}"]
        if self.kind == "DATA_BLOCK":
            out += ["STRUCT", f"  DATA : ARRAY [0 .. {max(self.size, 1) - 1}] OF BYTE;",
                    "END_STRUCT;", "BEGIN", f"END_{self.kind}"]
            return "\n".join(out)
        if self.temp:
            out += ["VAR_TEMP", *(f"  {t};" for t in self.temp), "END_VAR"]
        out.append("BEGIN")
        out += [line.render() for line in self.lines]
        out.append(f"END_{self.kind}")
        return "\n".join(out)


@dataclass
class AwlProgram:
    """The export: its blocks, where the operands went, what is left for a person."""

    name: str
    blocks: list[Block]
    layout: Layout
    #: the IL operand as written -> its S7 address, every bit and byte the program uses
    operands: dict[str, str]
    #: function block name as declared -> its FC number
    function_names: dict[str, int]
    unfinished: list[Unfinished]

    def symbol_table(self, symbols: SymbolTable) -> str:
        """The symbol table in awlsim's CSV form (name; address; type; comment): the
        function blocks' names for their FCs, the data blocks, and each name of the
        program's symbol table whose operand the program uses."""
        rows = [(shown, f"FC {n}", f"FC {n}", f"function block {shown}")
                for shown, n in self.function_names.items()]
        rows += [("IL_MACHINE", f"DB {at.STATE_DB}", f"DB {at.STATE_DB}",
                  "register, accumulators, constant register, clock, I2, PSeg"),
                 ("IL_TIMERS", f"DB {at.TIMER_DB}", f"DB {at.TIMER_DB}",
                  "remaining 10 ms ticks"),
                 ("IL_COUNTERS", f"DB {at.COUNTER_DB}", f"DB {at.COUNTER_DB}", "counts"),
                 ("IL_VARIABLES", f"DB {at.VARIABLE_DB}", f"DB {at.VARIABLE_DB}",
                  "the declared variables")]
        for name, operand in symbols.entries.values():
            address = self.operands.get(operand)
            if address is not None and not address.startswith("DB"):
                rows.append((name, address, _TYPES[address.split()[0]], operand))
        return "".join(";".join(f'"{cell}"' for cell in row) + "\n" for row in rows)

    def render(self) -> str:
        head = [f"// {self.name}: exported by asictl from AS-i Control IL (docs/migrate.md)"]
        if self.unfinished:
            head.append(f"// {len(self.unfinished)} thing(s) to finish by hand: search for TODO")
            head += [f"// {TODO}: {left}" for left in self.unfinished]
        return "\n\n".join(["\n".join(head), *(b.render() for b in self.blocks)]) + "\n"


TODO = "TODO"


class _Translator:
    """One block's body: the IL statements in order, with the register's whereabouts."""

    def __init__(self, export: _Export, scope: Scope, main: bool) -> None:
        self.export = export
        self.scope = scope
        self.main = main
        self.lines: list[Line] = []
        #: True while S7's RLO holds the IL register in an open logic string (/FC = 1);
        #: False when the RLO bit of DB 1 holds it and /FC is 0
        self.open = False
        #: True while S7's RLO holds the register though the string is closed (after
        #: ``= RLO``, =, S and R, until something changes S7's RLO or a jump lands)
        self.rlo_held = False
        self.labels = {key(s.name): export.label() for s in scope.statements
                       if isinstance(s, ast.Label)}

    def emit(self, op: str, operand: str = "", comment: str = "", label: str = "") -> None:
        self.lines.append(Line(op, operand, label, comment))
        if label or op not in _KEEP_RLO:
            self.rlo_held = False


    def close(self) -> None:
        """End an open logic string: the register back into DB 1, /FC 0."""
        if self.open:
            self.emit("=", at.RLO)
            self.open = False
            self.rlo_held = True

    def register(self) -> None:
        """S7's RLO := the IL register, whatever state the last line left."""
        if not self.open:
            self.emit("A", at.RLO)
            self.open = True

    def translate(self) -> list[Line]:
        for index, statement in enumerate(self.scope.statements):
            source = il_comment(statement)
            if source:
                self.emit("", comment=source)
            why = gap(statement, set(self.export.functions))
            if why is not None and not isinstance(statement, ast.GatingLine):
                self.close()
                self.export.unfinished.append(unfinished(statement, why, self.export.name))
                self.emit("", comment=f"{TODO}: finish by hand: {statement.to_source()}")
                self.emit("NOP", "0")
                if isinstance(statement, ast.Param):
                    self.param()
                continue
            self.statement(statement, index)
        self.close()
        return self.lines

    # ------------------------------------------------------------------ statements

    def statement(self, statement: ast.Statement | ast.GatingLine, index: int) -> None:
        match statement:
            case ast.Logic(op=op, operand=operand):
                self.logic(op, operand, first=index in self.scope.first_check)
            case ast.Store(op=op, operand=operand):
                self.store(op, operand)
            case ast.Not():
                if self.open:
                    self.emit("NOT")
                else:
                    self.emit("AN", at.RLO)
                    self.open = True
            case ast.Load(operand=operand):
                self.load(operand)
            case ast.Transfer(operand=operand):
                self.close()
                self.emit("L", at.ACCU1)
                self.transfer(operand)
            case ast.Arith(op=op):
                self.emit("L", at.ACCU2_LOW)
                self.emit("L", at.ACCU1_LOW)
                self.emit("+I" if op is ast.ArithOp.ADD else "-I")
                self.emit("AW", "W#16#FF")
                self.emit("T", at.ACCU1)
            case ast.Compare(op=op):
                self.close()
                self.emit("L", at.ACCU2_LOW)
                self.emit("L", at.ACCU1_LOW)
                self.emit(_COMPARE[op])
                self.emit("=", at.RLO)
            case ast.Count(op=op, counter=counter):
                self.count(op, counter.address)
            case ast.SegmentEnd():
                pass
            case ast.Label(name=name):
                self.close()
                self.emit("NOP", "0", label=self.labels[key(name)])
            case ast.BlockEnd(kind=kind):
                self.close()
                if kind is ast.EndKind.BEC:
                    self.emit("A", at.RLO)
                    self.emit("JC" if self.main else "BEC", self.export.end if self.main else "")
                elif self.main:
                    self.emit("JU", self.export.end)
                else:
                    self.emit("BEU")
            case ast.Jump(conditional=conditional, label=label):
                self.close()
                if conditional:
                    self.emit("A", at.RLO)
                self.emit("JC" if conditional else "JU", self.labels[key(label)])
            case ast.CallFB(conditional=conditional, name=name):
                self.call(conditional, name)
            case ast.Param() | ast.Asm():
                raise AssertionError(f"{statement.to_source()} is left for a person")
            case ast.GatingLine(target=target, terms=terms):
                for n, term in enumerate(terms):
                    op = (ast.LogicOp.O if term.op is ast.GatingOp.OR else ast.LogicOp.A)
                    if term.negated:
                        op = ast.LogicOp.ON if op is ast.LogicOp.O else ast.LogicOp.AN
                    self.logic(op, term.operand, first=n == 0)
                self.store(ast.StoreOp.ASSIGN, target)
            case _:
                assert_never(statement)

    def param(self) -> None:
        """What PARAM does around the send, which is left for a person: the slave and the
        parameter into PSeg 0 and 1, and F 127 saying "not sent" (an answer nobody gave
        leaves PSeg 0 holding the slave: only slave 0 reads as sent)."""
        skip, unsent = self.export.label(), self.export.label()
        pseg = ast.OperandKind.PSEG
        self.emit("A", at.RLO)
        self.emit("JCN", skip)
        self.emit("L", at.KREG)
        self.emit("SRW", "4")
        self.emit("AW", "W#16#1F")
        self.emit("T", self.export.layout.byte(ast.Operand.of(pseg, 0)))
        self.emit("L", at.KREG)
        self.emit("AW", "W#16#F")
        self.emit("T", self.export.layout.byte(ast.Operand.of(pseg, 1)))
        store = self.export.label()
        self.emit("L", self.export.layout.byte(ast.Operand.of(pseg, 0)))
        self.emit("L", "0")
        self.emit("==I")
        self.emit("JCN", unsent)
        self.emit("L", f"MB {PARAM_FLAG}")
        self.emit("AW", "W#16#70")
        self.emit("L", self.export.layout.byte(ast.Operand.of(pseg, 1)))
        self.emit("OW")
        self.emit("OW", "W#16#80")
        self.emit("JU", store)
        self.emit("L", f"MB {PARAM_FLAG}", label=unsent)
        self.emit("AW", "W#16#70")
        self.emit("T", f"MB {PARAM_FLAG}", label=store)
        self.emit("NOP", "0", label=skip)

    def call(self, conditional: bool, name: str) -> None:
        self.close()
        number = self.export.functions[key(name)]
        skip = self.export.label() if conditional else ""
        if conditional:
            self.emit("A", at.RLO)
            self.emit("JCN", skip)
        self.emit("CALL", f"FC {number}")
        if conditional:
            self.emit("NOP", "0", label=skip)

    def logic(self, op: ast.LogicOp, operand: ast.Operand, *, first: bool) -> None:
        if operand.kind in (K.T, K.C):
            self.close()
            self.read_word(operand)
            self.emit("L", "0")
            self.emit("<>I")
            self.emit("=", at.STATUS)
            address = at.STATUS
        else:
            address = self.export.layout.bit(operand)
        if first:
            if self.open:
                self.emit("CLR")  # /FC 0: the next A loads
        else:
            self.register()
        self.emit(op.value, address)
        self.open = True

    def store(self, op: ast.StoreOp, operand: ast.Operand) -> None:
        if operand.kind in (K.T, K.C):
            self.close()
            skip = self.export.label()
            self.emit("A", at.RLO)
            self.emit("JCN", skip)
            if op is ast.StoreOp.SET:
                self.emit("L", at.KREG)
                self.clamp()
            else:
                self.emit("L", "0")
            self.write_word(operand)
            self.emit("NOP", "0", label=skip)
            return
        held = self.export.layout.held_at_zero(operand)
        if held is not None:
            self.close()  # the register in DB 1, as after a store
            self.emit("", comment=held)
            return
        if self.open:
            self.close()  # S7's RLO still holds the register
        elif not self.rlo_held:
            self.emit("A", at.RLO)
            self.open = False
            self.rlo_held = True
        self.emit(op.value, self.export.layout.bit(operand))
        self.open = False  # =, S, R leave /FC 0 and S7's RLO as it was

    def load(self, operand: ast.Operand) -> None:
        self.close()
        kind = operand.kind
        if kind in (K.KT, K.KC, K.KP):
            value = {K.KT: (operand.address + 9) // 10, K.KC: operand.address,
                     K.KP: operand.address << 4 | operand.bit}[kind]
            self.emit("L", _word(value))
            self.emit("T", at.KREG)
            return
        self.emit("L", at.ACCU1)
        self.emit("T", at.ACCU2)
        if kind in (K.KB, K.KW):
            self.emit("L", _word(operand.address))
        else:
            self.read_word(operand)
        self.emit("T", at.ACCU1)

    def read_word(self, operand: ast.Operand) -> None:
        """S7's ACCU1 := the IL word or byte operand (zero-extended)."""
        layout = self.export.layout
        n = operand.address
        match operand.kind:
            case K.FW:
                self.emit("L", f"MW {n}")
            case K.T:
                self.export.timers.add(n)
                self.emit("L", layout.timer(n))
            case K.C:
                if layout.counter_mapped(n):
                    low, high = layout.mapped_counter_bytes(n)
                    self.emit("L", high)
                    self.emit("AW", "W#16#F")
                    self.emit("SLW", "8")
                    self.emit("L", low)
                    self.emit("OW")
                else:
                    self.emit("L", layout.counter(n))
            case (
                K.I | K.I2 | K.Q | K.F | K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.VAR | K.KT |
                K.KC | K.KB | K.KW | K.KP
            ):
                self.emit("L", layout.byte(operand))
            case _:
                assert_never(operand.kind)

    def transfer(self, operand: ast.Operand) -> None:
        """The IL operand := S7's ACCU1 (its low byte for a byte operand); a flag byte
        gets only the bits it keeps (``Layout.keeps``)."""
        layout = self.export.layout
        match operand.kind:
            case K.FW:
                n = operand.address
                self.mask(layout.keeps(n) << 8 | layout.keeps(n + 1), 0xFFFF)
                self.emit("T", f"MW {n}")
            case K.FY:
                self.mask(layout.keeps(operand.address), 0xFF)
                self.emit("T", layout.byte(operand))
            case K.T | K.C:
                self.clamp()
                self.write_word(operand)
            case (
                K.I | K.I2 | K.Q | K.F | K.IB | K.I2B | K.QB | K.PSEG | K.VAR | K.KT |
                K.KC | K.KB | K.KW | K.KP
            ):
                self.emit("T", layout.byte(operand))
            case _:
                assert_never(operand.kind)

    def mask(self, keeps: int, everything: int) -> None:
        """ACCU1 := ACCU1 AND keeps, unless keeps is every bit written."""
        if keeps != everything:
            self.emit("AW", _word(keeps))

    def clamp(self) -> None:
        """ACCU1 := min(ACCU1, 4095), unsigned (timers and counters hold 12 bits)."""
        done = self.export.label()
        self.emit("L", f"L#{TC_MAX_VALUE}")
        self.emit("<=D")  # ACCU2, the value (zero-extended), <= 4095?
        self.emit("JC", done)
        self.emit("TAK")  # above: ACCU2 := the value, ACCU1 := 4095 after the next TAK
        self.emit("NOP", "0", label=done)
        self.emit("TAK")

    def write_word(self, operand: ast.Operand) -> None:
        layout = self.export.layout
        n = operand.address
        if operand.kind is K.T:
            self.export.timers.add(n)
            self.emit("T", layout.timer(n))
        elif layout.counter_mapped(n):
            low, high = layout.mapped_counter_bytes(n)
            self.emit("T", low)
            self.emit("SRW", "8")
            self.emit("T", high)
        else:
            self.emit("T", layout.counter(n))

    def count(self, op: ast.CountOp, n: int) -> None:
        self.close()
        counter = ast.Operand.of(K.C, n, width=ast.Width.WORD)
        done = self.export.label()
        self.emit("A", at.RLO)
        if op is ast.CountOp.STP:
            down = self.export.label()
            self.emit("JCN", down)
            self.step(counter, up=True, done=done)
            self.emit("JU", done)
            self.emit("NOP", "0", label=down)
            self.step(counter, up=False, done=done)
        else:
            self.emit("JCN", done)
            self.step(counter, up=op is ast.CountOp.CU, done=done)
        self.emit("NOP", "0", label=done)

    def step(self, counter: ast.Operand, *, up: bool, done: str) -> None:
        """One count up or down, saturating at 4095 and 0."""
        self.read_word(counter)
        self.emit("L", str(TC_MAX_VALUE) if up else "0")
        self.emit("==I")
        self.emit("JC", done)
        self.emit("TAK")
        self.emit("L", "1")
        self.emit("+I" if up else "-I")
        self.write_word(counter)


#: What leaves S7's RLO alone (the accumulator and word operations, =, S, R).
_KEEP_RLO = frozenset({"=", "S", "R", "L", "T", "TAK", "AW", "OW", "SLW", "SRW", "+I", "-I",
                       "+D", "-D", "/D", "MOD", ""})

_COMPARE = {
    ast.CompareOp.EQ: "==I", ast.CompareOp.NE: "<>I", ast.CompareOp.GT: ">I",
    ast.CompareOp.GE: ">=I", ast.CompareOp.LT: "<I", ast.CompareOp.LE: "<=I",
}


def _word(value: int) -> str:
    return f"W#16#{value:X}"


class _Export:
    """What the blocks share: labels, the FC numbers, the timers used, the leftovers."""

    def __init__(self, name: str, program: Program) -> None:
        self.name = name
        self.program = program
        self.layout = layout_of(program.modules(), program.options.map_counters)
        self.functions = {name: n for n, name in enumerate(program.blocks, start=1)}
        self.unfinished: list[Unfinished] = []
        self.timers: set[int] = set()
        self._labels = 0
        self.end = self.label()

    def label(self) -> str:
        """A new jump label: S7 allows four characters."""
        self._labels += 1
        return f"M{self._labels:03d}"


def export_awl(name: str, program: Program) -> AwlProgram:
    """Translate a checked program (no errors) to AWL."""
    export = _Export(name, program)
    functions = []
    for block_name, module in program.blocks.items():
        body = _Translator(export, scope_of(module), main=False).translate()
        functions.append(Block("FUNCTION", f"FC {export.functions[block_name]}",
                               f"function block {_declared(program, block_name)}", body))
    main = _Translator(export, scope_of(program.main), main=True).translate()
    ob1 = Block("ORGANIZATION_BLOCK", "OB 1", "the program cycle",
                [*_cycle_start(export), *main, *_cycle_end(export)],
                temp=("OB1_INFO : ARRAY [0 .. 19] OF BYTE", "NOW : TIME"))
    ob100 = Block("ORGANIZATION_BLOCK", "OB 100", "start-up: the 10 ms clock begins",
                  list(_startup()), temp=("OB100_INFO : ARRAY [0 .. 19] OF BYTE",
                                          "NOW : TIME"))
    data = [
        Block("DATA_BLOCK", f"DB {at.STATE_DB}", "the IL machine: register, ACCU1/2, "
              "constant register, clock, I2, last inputs, PSeg", size=at.STATE_SIZE),
        Block("DATA_BLOCK", f"DB {at.TIMER_DB}", "timers: remaining 10 ms ticks",
              size=2 * (max(export.timers, default=0) + 1)),
        Block("DATA_BLOCK", f"DB {at.COUNTER_DB}", "counters", size=2 * 1024),
        Block("DATA_BLOCK", f"DB {at.VARIABLE_DB}", "the declared variables",
              size=export.layout.variable_bytes),
    ]
    export.unfinished += host_flags(program, export.layout.flag)
    names = {_declared(program, block): n for block, n in export.functions.items()}
    return AwlProgram(name, [*data, *functions, ob100, ob1], export.layout,
                      dict(_operands(program, export.layout)), names, export.unfinished)


def _declared(program: Program, block: str) -> str:
    """A function block's name as its declaration writes it."""
    decl = program.fb_decls.get(block)
    return decl.name if decl is not None else block


#: The S7 type of an address, by its area.
_TYPES = {"I": "BOOL", "Q": "BOOL", "M": "BOOL", "IB": "BYTE", "QB": "BYTE", "MB": "BYTE",
          "MW": "WORD"}


def _startup() -> Iterator[Line]:
    yield Line("CALL", "SFC 64 (RET_VAL := #NOW)", comment="TIME_TCK: milliseconds")
    yield Line("L", "#NOW")
    yield Line("T", at.CLOCK_LAST)
    yield Line("L", "L#0")
    yield Line("T", at.CLOCK_REST)


def _cycle_start(export: _Export) -> Iterator[Line]:
    """The master's cycle: I2 := the inputs of the last cycle; the register starts at 0;
    the timers count down the 10 ms ticks since the last cycle."""
    yield Line(comment="I2: the inputs as the last cycle left them")
    for offset in range(0, at.IMAGE_BYTES, 4):
        yield Line("L", f"DB{at.STATE_DB}.DBD {at.PREVIOUS_BASE + offset}")
        yield Line("T", f"DB{at.STATE_DB}.DBD {at.I2_BASE + offset}")
    yield Line("CLR", comment="the single-bit register starts every cycle at 0")
    yield Line("=", at.RLO)
    yield Line(comment="10 ms ticks since the last cycle: SFC 64's milliseconds, the "
                       "remainder carried, the 31-bit wrap undone")
    wrapped = export.label()
    yield Line("CALL", "SFC 64 (RET_VAL := #NOW)")
    yield Line("L", "#NOW")
    yield Line("L", at.CLOCK_LAST)
    yield Line("-D")
    yield Line("JPZ", wrapped)
    yield Line("L", "L#2147483647")
    yield Line("+D")
    yield Line("L", "L#1")
    yield Line("+D")
    yield Line("NOP", "0", label=wrapped)
    yield Line("L", at.CLOCK_REST)
    yield Line("+D")
    yield Line("T", at.CLOCK_REST)
    yield Line("L", "L#10")
    yield Line("/D")
    yield Line("T", at.TICKS)
    yield Line("L", at.CLOCK_REST)
    yield Line("L", "L#10")
    yield Line("MOD")
    yield Line("T", at.CLOCK_REST)
    yield Line("L", "#NOW")
    yield Line("T", at.CLOCK_LAST)
    for n in sorted(export.timers):
        zero = export.label()
        yield Line("L", at.Layout.timer(n), comment=f"T {n} counts down")
        yield Line("L", at.TICKS)
        yield Line("-D")
        yield Line("JPZ", zero)
        yield Line("L", "L#0")
        yield Line("T", at.Layout.timer(n), label=zero)


def _cycle_end(export: _Export) -> Iterator[Line]:
    yield Line("NOP", "0", label=export.end, comment="the end of the cycle: the inputs "
                                                      "for I2")
    for offset in range(0, at.IMAGE_BYTES, 4):
        yield Line("L", f"ID {offset}")
        yield Line("T", f"DB{at.STATE_DB}.DBD {at.PREVIOUS_BASE + offset}")


def _operands(program: Program, layout: Layout) -> Iterator[tuple[str, str]]:
    """Every bit and byte operand the program names, as written, with its S7 address."""
    for module in program.modules():
        for statement in module.code():
            for operand, _ in ast.operands(statement):
                if operand.kind in ast.IMAGE_BITS or (operand.kind is K.VAR
                                                      and operand.bit >= 0):
                    yield str(operand), layout.bit(operand)
                elif operand.kind in (*ast.SLAVE_BYTES, K.FY, K.PSEG, K.VAR):
                    yield str(operand), layout.byte(operand)
                elif operand.kind is K.FW:
                    yield str(operand), f"MW {operand.address}"
                elif operand.kind is K.T:
                    yield f"T {operand.address}", layout.timer(operand.address)
                elif operand.kind is K.C and not layout.counter_mapped(operand.address):
                    yield f"C {operand.address}", layout.counter(operand.address)
