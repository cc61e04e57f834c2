"""A checked IL program as IEC 61131-3 Structured Text (docs/migrate.md).

One PROGRAM for the main program and a FUNCTION_BLOCK per function block, over global
variables: the IL shares everything between them (flags, the register, the
accumulators), so the blocks have no data of their own and one instance each. The
operands the program uses are located variables at the addresses the AWL export uses
(``I 1.0`` is ``%IX0.4``, ``F 0.2`` is ``%MX0.2``, ``FY 11`` is ``%MB11``), named by
the program's symbols or else by the operand (``I1_0``, ``FY11``); the IL machine (the
register, ACCU1/2, the constant register, I2, PSeg, timers, counters) is plain global
variables with an ``IL_`` prefix. Every translated line has the IL line it came from
as a comment above it.

The IL's jumps have no ST equivalent; a body with labels, jumps or block ends becomes
a loop over a CASE of its pieces (each piece runs to a jump or the next label), which
keeps every path exact. Timers count down the 10 ms ticks of ``TIME()``, as the AWL's
count SFC 64's milliseconds.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from itertools import pairwise
from typing import assert_never

from asictl.export.gaps import Unfinished, gap, host_flags, il_comment, unfinished
from asictl.export.layout import Layout, layout_of, slave_bit
from asictl.il import ast
from asictl.il.ast import key
from asictl.il.language import COUNTER_FLAG_BASE, PARAM_FLAG, TC_MAX_VALUE
from asictl.il.loader import Program
from asictl.il.oracle import Scope, scope_of
from asictl.observe.symbols import SymbolTable

K = ast.OperandKind
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


@dataclass
class StLine:
    """One line of ST at an indentation depth (a comment alone when ``text`` is empty)."""

    text: str
    depth: int = 0
    comment: str = ""

    def render(self) -> str:
        comment = f"(* {self.comment.replace('*)', '* )')} *)" if self.comment else ""
        return "    " * self.depth + (f"{self.text}  {comment}" if self.text and comment
                                      else self.text or comment)


@dataclass(frozen=True)
class Var:
    """A variable declaration: name, type as ST writes it, a located address or ''."""

    name: str
    type: str
    address: str = ""
    comment: str = ""

    def render(self) -> str:
        at = f" AT {self.address}" if self.address else ""
        return StLine(f"{self.name}{at} : {self.type};", 1, self.comment).render()


@dataclass
class Pou:
    """A PROGRAM or a FUNCTION_BLOCK."""

    kind: str
    name: str
    title: str
    lines: list[StLine] = field(default_factory=list)
    local: tuple[Var, ...] = ()

    def body(self) -> str:
        return "\n".join(line.render() for line in self.lines)

    def render(self) -> str:
        out = [f"{self.kind} {self.name}", f"(* {self.title} *)"]
        if self.local:
            out += ["VAR", *(v.render() for v in self.local), "END_VAR"]
        out += [self.body(), f"END_{self.kind}"]
        return "\n".join(out)


@dataclass
class StProgram:
    name: str
    globals: list[Var]
    pous: list[Pou]
    #: the IL operand as written -> its ST variable
    variables: dict[str, str]
    unfinished: list[Unfinished]

    def render(self) -> str:
        head = f"(* {self.name}: exported by asictl from AS-i Control IL (docs/migrate.md) *)"
        if self.unfinished:
            head += f"\n(* {len(self.unfinished)} thing(s) to finish by hand: search for TODO *)"
            head += "".join("\n" + StLine("", 0, f"TODO: {left}").render()
                            for left in self.unfinished)
        glob = "\n".join(["VAR_GLOBAL", *(v.render() for v in self.globals), "END_VAR"])
        return "\n\n".join([head, glob, *(p.render() for p in self.pous)]) + "\n"


class _Names:
    """The located variables: one per operand the program uses, named once."""

    def __init__(self, layout: Layout, symbols: SymbolTable) -> None:
        self.layout = layout
        self.symbols = symbols
        #: operand text -> its located variable
        self.located: dict[str, Var] = {}

    def _declare(self, operand: str, default: str, at: str, kind: str) -> str:
        if operand not in self.located:
            name = self.symbols.name_of(operand)
            taken = {v.name for v in self.located.values()}
            if name is None or not _IDENTIFIER.match(name) or name in taken:
                name = default
            self.located[operand] = Var(name, kind, at, operand)
        return self.located[operand].name

    def _located(self, operand: ast.Operand, s7: str, kind: str) -> str:
        """The located variable of an image or flag operand, at the AWL's address."""
        area, number = s7.split()
        at = f"%{area[0]}{area[1:] or 'X'}{number}"  # I 0.4 -> %IX0.4, MB 11 -> %MB11
        default = str(operand).replace(" ", "").replace(".", "_")
        return self._declare(str(operand), default, at, kind)

    def bit(self, operand: ast.Operand) -> str:
        a, b = operand.address, operand.bit
        match operand.kind:
            case K.I | K.Q | K.F:
                return self._located(operand, self.layout.bit(operand), "BOOL")
            case K.I2:
                byte, bit = slave_bit(a, b)
                return f"IL_I2[{byte}].{bit}"
            case K.VAR:
                return f"{operand.name}[{a}].{b}"
            case (
                K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.FW | K.T | K.C | K.KT | K.KC | K.KB |
                K.KW | K.KP
            ):
                raise AssertionError(f"{operand} is no plain bit")
            case _:
                assert_never(operand.kind)

    def byte(self, operand: ast.Operand) -> str:
        a = operand.address
        match operand.kind:
            case K.IB | K.QB | K.FY:
                return self._located(operand, self.layout.byte(operand), "BYTE")
            case K.I2B:
                return f"IL_I2[{a // 2}]"
            case K.PSEG:
                return f"IL_PSEG[{a}]"
            case K.VAR:
                return f"{operand.name}[{a}]"
            case K.I | K.I2 | K.Q | K.F | K.FW | K.T | K.C | K.KT | K.KC | K.KB | K.KW | K.KP:
                raise AssertionError(f"{operand} is no byte")
            case _:
                assert_never(operand.kind)

    def flag_byte(self, n: int) -> str:
        return self.byte(ast.Operand.of(K.FY, n))


class _Body:
    """One POU's statements, as ST, with the register in IL_RLO."""

    def __init__(self, export: _Export, scope: Scope) -> None:
        self.export = export
        self.names = export.names
        self.scope = scope
        self.lines: list[StLine] = []
        self.depth = 0

    def emit(self, text: str, comment: str = "") -> None:
        self.lines.append(StLine(text, self.depth, comment))

    # ------------------------------------------------------------------ pieces

    def translate(self) -> list[StLine]:
        statements = self.scope.statements
        flow = any(isinstance(s, ast.Label | ast.Jump)
                   or (isinstance(s, ast.BlockEnd) and i < len(statements) - 1)
                   or (isinstance(s, ast.BlockEnd) and s.kind is ast.EndKind.BEC)
                   for i, s in enumerate(statements))
        if not flow:
            for index, statement in enumerate(statements):
                self.statement(statement, index, None)
            return self.lines
        pieces = self._pieces()
        self.emit("IL_PC := 0;")
        self.emit("WHILE IL_PC >= 0 DO")
        self.depth += 1
        self.emit("CASE IL_PC OF")
        for number, (start, end) in enumerate(pieces):
            self.emit(f"{number}:")
            self.depth += 1
            ended = False
            for index in range(start, end):
                ended = self.statement(statements[index], index, pieces) or ended
            if not ended:
                self.emit(f"IL_PC := {number + 1 if number + 1 < len(pieces) else -1};")
            self.depth -= 1
        self.emit("ELSE")
        self.emit("    IL_PC := -1;")
        self.emit("END_CASE;")
        self.depth -= 1
        self.emit("END_WHILE;")
        return self.lines

    def _pieces(self) -> list[tuple[int, int]]:
        """The statements cut before each label and after each jump or block end."""
        cuts = {0, len(self.scope.statements)}
        for index, statement in enumerate(self.scope.statements):
            if isinstance(statement, ast.Label):
                cuts.add(index)
            elif isinstance(statement, ast.Jump | ast.BlockEnd):
                cuts.add(index + 1)
        edges = sorted(cuts)
        return [(a, b) for a, b in pairwise(edges) if a < b]

    def _piece_of(self, index: int, pieces: list[tuple[int, int]]) -> int:
        return next(n for n, (a, b) in enumerate(pieces) if a <= index < b)

    def _next(self, index: int, pieces: list[tuple[int, int]] | None) -> str:
        assert pieces is not None
        n = self._piece_of(index, pieces) + 1
        return str(n if n < len(pieces) else -1)

    # ------------------------------------------------------------------ statements

    def statement(self, statement: ast.Statement | ast.GatingLine, index: int,
                  pieces: list[tuple[int, int]] | None) -> bool:
        """Emit one statement; True when it ended its piece (set IL_PC)."""
        comment = il_comment(statement)
        if comment:
            self.emit("", comment)
        why = gap(statement, set(self.export.blocks))
        if why is not None and not isinstance(statement, ast.GatingLine):
            self.export.unfinished.append(unfinished(statement, why, self.export.name))
            self.emit("", f"TODO: finish by hand: {statement.to_source()}")
            if isinstance(statement, ast.Param):
                self.param()
            return False
        match statement:
            case ast.Logic(op=op, operand=operand):
                self.logic(op, self.read_bit(operand), first=index in self.scope.first_check)
            case ast.Store(op=op, operand=operand):
                self.store(op, operand)
            case ast.Not():
                self.emit("IL_RLO := NOT IL_RLO;")
            case ast.Load(operand=operand):
                self.load(operand)
            case ast.Transfer(operand=operand):
                self.transfer(operand)
            case ast.Arith(op=op):
                sign = "+" if op is ast.ArithOp.ADD else "-"
                self.emit(f"IL_ACCU1 := ((IL_ACCU2 AND 16#FF) {sign} (IL_ACCU1 AND 16#FF)) "
                          "AND 16#FF;")
            case ast.Compare(op=op):
                self.emit(f"IL_RLO := (IL_ACCU2 AND 16#FF) {_COMPARE[op]} (IL_ACCU1 AND 16#FF);")
            case ast.Count(op=op, counter=counter):
                self.count(op, counter.address)
            case ast.SegmentEnd() | ast.Label():
                pass
            case ast.BlockEnd(kind=kind):
                if kind is ast.EndKind.BEC:
                    self.emit(f"IF IL_RLO THEN IL_PC := -1; ELSE IL_PC := "
                              f"{self._next(index, pieces)}; END_IF;")
                else:
                    self.emit("IL_PC := -1;")
                return True
            case ast.Jump(conditional=conditional, label=label):
                assert pieces is not None
                target = self._piece_of(self.scope.labels[key(label)], pieces)
                if conditional:
                    self.emit(f"IF IL_RLO THEN IL_PC := {target}; ELSE IL_PC := "
                              f"{self._next(index, pieces)}; END_IF;")
                else:
                    self.emit(f"IL_PC := {target};")
                return True
            case ast.CallFB(conditional=conditional, name=name):
                call = f"IL_FB_{self.export.blocks[key(name)]}();"
                self.emit(f"IF IL_RLO THEN {call} END_IF;" if conditional else call)
            case ast.GatingLine(target=target, terms=terms):
                for n, term in enumerate(terms):
                    op = ast.LogicOp.O if term.op is ast.GatingOp.OR else ast.LogicOp.A
                    if term.negated:
                        op = ast.LogicOp.ON if op is ast.LogicOp.O else ast.LogicOp.AN
                    self.logic(op, self.read_bit(term.operand), first=n == 0)
                self.store(ast.StoreOp.ASSIGN, target)
            case ast.Param() | ast.Asm():
                raise AssertionError(f"{statement.to_source()} is left for a person")
            case _:
                assert_never(statement)
        return False

    def logic(self, op: ast.LogicOp, value: str, *, first: bool) -> None:
        if op in (ast.LogicOp.AN, ast.LogicOp.ON):
            value = f"NOT {value}"
        if first:
            self.emit(f"IL_RLO := {value};")
        else:
            joined = "AND" if op in (ast.LogicOp.A, ast.LogicOp.AN) else "OR"
            self.emit(f"IL_RLO := IL_RLO {joined} {value};")

    def read_bit(self, operand: ast.Operand) -> str:
        if operand.kind in (K.T, K.C):
            return f"({self.word(operand)} <> 0)"
        return self.names.bit(operand)

    def store(self, op: ast.StoreOp, operand: ast.Operand) -> None:
        if operand.kind in (K.T, K.C):
            value = "MIN(IL_KREG, 4095)" if op is ast.StoreOp.SET else "0"
            self.emit("IF IL_RLO THEN")
            self.depth += 1
            self.write_word(operand, value)
            self.depth -= 1
            self.emit("END_IF;")
            return
        held = self.names.layout.held_at_zero(operand)
        if held is not None:
            self.emit("", held)
            return
        target = self.names.bit(operand)
        if op is ast.StoreOp.ASSIGN:
            self.emit(f"{target} := IL_RLO;")
        else:
            value = "TRUE" if op is ast.StoreOp.SET else "FALSE"
            self.emit(f"IF IL_RLO THEN {target} := {value}; END_IF;")

    def word(self, operand: ast.Operand) -> str:
        """An expression of type WORD for a word or byte operand."""
        n = operand.address
        match operand.kind:
            case K.FW:
                high, low = self.names.flag_byte(n), self.names.flag_byte(n + 1)
                return f"(SHL(BYTE_TO_WORD({high}), 8) OR BYTE_TO_WORD({low}))"
            case K.T:
                self.export.timers.add(n)
                return f"IL_T[{n}]"
            case K.C:
                if self.names.layout.counter_mapped(n):
                    low = self.names.flag_byte(COUNTER_FLAG_BASE + 2 * n)
                    high = self.names.flag_byte(COUNTER_FLAG_BASE + 2 * n + 1)
                    return f"(SHL(BYTE_TO_WORD({high}) AND 16#F, 8) OR BYTE_TO_WORD({low}))"
                self.export.counters.add(n)
                return f"IL_C[{n}]"
            case (
                K.I | K.I2 | K.Q | K.F | K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.VAR | K.KT |
                K.KC | K.KB | K.KW | K.KP
            ):
                return f"BYTE_TO_WORD({self.names.byte(operand)})"
            case _:
                assert_never(operand.kind)

    def write_word(self, operand: ast.Operand, value: str) -> None:
        n = operand.address
        if operand.kind is K.T:
            self.export.timers.add(n)
            self.emit(f"IL_T[{n}] := {value};")
        elif self.names.layout.counter_mapped(n):
            low = self.names.flag_byte(COUNTER_FLAG_BASE + 2 * n)
            high = self.names.flag_byte(COUNTER_FLAG_BASE + 2 * n + 1)
            self.emit(f"IL_W := {value};")
            self.emit(f"{low} := WORD_TO_BYTE(IL_W);")
            self.emit(f"{high} := WORD_TO_BYTE(SHR(IL_W, 8));")
        else:
            self.export.counters.add(n)
            self.emit(f"IL_C[{n}] := {value};")

    def load(self, operand: ast.Operand) -> None:
        kind = operand.kind
        if kind in (K.KT, K.KC, K.KP):
            constant = {K.KT: (operand.address + 9) // 10, K.KC: operand.address,
                        K.KP: operand.address << 4 | operand.bit}[kind]
            self.emit(f"IL_KREG := {constant};")
            return
        self.emit("IL_ACCU2 := IL_ACCU1;")
        value = f"{operand.address}" if kind in (K.KB, K.KW) else self.word(operand)
        self.emit(f"IL_ACCU1 := {value};")

    def transfer(self, operand: ast.Operand) -> None:
        match operand.kind:
            case K.FW:
                n = operand.address
                self.write_flag_byte(n, "SHR(IL_ACCU1, 8)")
                self.write_flag_byte(n + 1, "IL_ACCU1")
            case K.FY:
                self.write_flag_byte(operand.address, "IL_ACCU1")
            case K.T | K.C:
                self.write_word(operand, f"MIN(IL_ACCU1, {TC_MAX_VALUE})")
            case (
                K.I | K.I2 | K.Q | K.F | K.IB | K.I2B | K.QB | K.PSEG | K.VAR | K.KT |
                K.KC | K.KB | K.KW | K.KP
            ):
                self.emit(f"{self.names.byte(operand)} := WORD_TO_BYTE(IL_ACCU1);")
            case _:
                assert_never(operand.kind)

    def write_flag_byte(self, n: int, word: str) -> None:
        """Flag byte ``n`` := the low byte of ``word``, but only the bits it keeps."""
        keeps = self.names.layout.keeps(n)
        masked = word if keeps == 0xFF else f"{word} AND 16#{keeps:X}"
        self.emit(f"{self.names.flag_byte(n)} := WORD_TO_BYTE({masked});")

    def count(self, op: ast.CountOp, n: int) -> None:
        counter = ast.Operand.of(K.C, n, width=ast.Width.WORD)
        value = self.word(counter)
        up = f"IF {value} < {TC_MAX_VALUE} THEN"
        down = f"IF {value} > 0 THEN"
        if op is ast.CountOp.STP:
            self.emit("IF IL_RLO THEN")
            self._step(counter, up, "+")
            self.emit("ELSE")
            self._step(counter, down, "-")
        else:
            self.emit("IF IL_RLO THEN")
            self._step(counter, up if op is ast.CountOp.CU else down,
                       "+" if op is ast.CountOp.CU else "-")
        self.emit("END_IF;")

    def _step(self, counter: ast.Operand, test: str, sign: str) -> None:
        self.depth += 1
        self.emit(test)
        self.depth += 1
        self.write_word(counter, f"{self.word(counter)} {sign} 1")
        self.depth -= 1
        self.emit("END_IF;")
        self.depth -= 1

    def param(self) -> None:
        """PARAM's bookkeeping around the send left for a person, as in the AWL."""
        flag = self.names.flag_byte(PARAM_FLAG)
        self.emit("IF IL_RLO THEN")
        self.depth += 1
        self.emit("IL_PSEG[0] := WORD_TO_BYTE(SHR(IL_KREG, 4) AND 16#1F);")
        self.emit("IL_PSEG[1] := WORD_TO_BYTE(IL_KREG AND 16#F);")
        self.emit(f"IF IL_PSEG[0] = 0 THEN {flag} := ({flag} AND 16#70) OR IL_PSEG[1] OR 16#80;")
        self.emit(f"ELSE {flag} := {flag} AND 16#70; END_IF;")
        self.depth -= 1
        self.emit("END_IF;")


_COMPARE = {
    ast.CompareOp.EQ: "=", ast.CompareOp.NE: "<>", ast.CompareOp.GT: ">",
    ast.CompareOp.GE: ">=", ast.CompareOp.LT: "<", ast.CompareOp.LE: "<=",
}


class _Export:
    def __init__(self, name: str, program: Program, symbols: SymbolTable) -> None:
        self.name = name
        self.program = program
        self.layout = layout_of(program.modules(), program.options.map_counters)
        self.names = _Names(self.layout, symbols)
        #: key(block) -> its POU's name
        self.blocks = {block: _declared(program, block) for block in program.blocks}
        self.timers: set[int] = set()
        self.counters: set[int] = set()
        self.unfinished: list[Unfinished] = []


def _declared(program: Program, block: str) -> str:
    decl = program.fb_decls.get(block)
    return decl.name if decl is not None else block


def export_st(name: str, program: Program, symbols: SymbolTable | None = None) -> StProgram:
    """Translate a checked program (no errors) to Structured Text."""
    export = _Export(name, program, symbols or SymbolTable())
    pous = []
    for block, module in program.blocks.items():
        body = _Body(export, scope_of(module)).translate()
        pous.append(Pou("FUNCTION_BLOCK", export.blocks[block],
                        f"function block {export.blocks[block]}", body,
                        (Var("IL_PC", "INT"),)))
    main = _Body(export, scope_of(program.main)).translate()
    program_name = re.sub(r"\W", "_", name.rsplit(".", 1)[0]) or "main"
    if not program_name[0].isalpha():
        program_name = f"P_{program_name}"
    pous.append(Pou("PROGRAM", program_name, "the program cycle",
                    [*_cycle_start(export), *main, *_cycle_end()],
                    (Var("IL_PC", "INT"), Var("IL_N", "INT"), Var("IL_NOW", "TIME"),
                     Var("IL_TICKS", "DINT"))))
    variables = {operand: var.name for operand, var in export.names.located.items()}
    export.unfinished += host_flags(program, lambda flag: variables.get(str(flag), str(flag)))
    return StProgram(name, list(_globals(export)), pous, variables, export.unfinished)


def _globals(export: _Export) -> Iterator[Var]:
    yield from export.names.located.values()
    byte16 = "ARRAY[0..15] OF BYTE"
    yield Var("IL_IN", byte16, "%IB0", "the AS-i input image")
    yield Var("IL_RLO", "BOOL", comment="the single-bit register")
    yield Var("IL_ACCU1", "WORD")
    yield Var("IL_ACCU2", "WORD")
    yield Var("IL_KREG", "WORD", comment="the constant register (L KT, L KC, L KP)")
    yield Var("IL_W", "WORD", comment="a counter's new value")
    yield Var("IL_I2", byte16, comment="I2: the inputs of the last cycle")
    yield Var("IL_LAST_IN", byte16)
    yield Var("IL_PSEG", byte16)
    yield Var("IL_CLOCK", "TIME", comment="TIME() at the last cycle")
    yield Var("IL_REST", "DINT", comment="milliseconds not yet a 10 ms tick")
    yield Var("IL_STARTED", "BOOL")
    yield Var("IL_T", f"ARRAY[0..{max(export.timers, default=0)}] OF WORD",
              comment="timers: remaining 10 ms ticks")
    yield Var("IL_C", f"ARRAY[0..{max(export.counters, default=0)}] OF WORD",
              comment="counters")
    for var, size in _variables(export.program):
        yield Var(var, f"ARRAY[0..{size - 1}] OF BYTE", comment="a declared variable")
    for name in export.blocks.values():
        yield Var(f"IL_FB_{name}", name)


def _variables(program: Program) -> Iterator[tuple[str, int]]:
    seen: set[str] = set()
    for module in program.modules():
        for section in module.sections_of(ast.DeclSection):
            for decl in section.declarations:
                if isinstance(decl, ast.VarDecl) and key(decl.name) not in seen:
                    seen.add(key(decl.name))
                    yield decl.name, decl.size


def _cycle_start(export: _Export) -> Iterator[StLine]:
    yield StLine("", 0, "the master's cycle: I2, the register at 0, the timers' ticks")
    yield StLine("FOR IL_N := 0 TO 15 DO IL_I2[IL_N] := IL_LAST_IN[IL_N]; END_FOR;")
    yield StLine("IL_RLO := FALSE;")
    yield StLine("IL_NOW := TIME();")
    yield StLine("IF NOT IL_STARTED THEN IL_CLOCK := IL_NOW; IL_STARTED := TRUE; END_IF;")
    yield StLine("IL_REST := IL_REST + TIME_TO_DINT(IL_NOW - IL_CLOCK);")
    yield StLine("IL_CLOCK := IL_NOW;")
    yield StLine("IL_TICKS := IL_REST / 10;")
    yield StLine("IL_REST := IL_REST MOD 10;")
    for n in sorted(export.timers):
        yield StLine(f"IF WORD_TO_DINT(IL_T[{n}]) > IL_TICKS THEN IL_T[{n}] := IL_T[{n}] - "
                     f"DINT_TO_WORD(IL_TICKS); ELSE IL_T[{n}] := 0; END_IF;")


def _cycle_end() -> Iterator[StLine]:
    yield StLine("", 0, "the end of the cycle: the inputs for I2")
    yield StLine("FOR IL_N := 0 TO 15 DO IL_LAST_IN[IL_N] := IL_IN[IL_N]; END_FOR;")

