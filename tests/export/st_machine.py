"""A small executor for the Structured Text that ``asictl export --to st`` writes, for
the tests: it parses the text with its own grammar (lark, LALR: Earley took a second a
program) and runs the PROGRAM cycle by cycle over byte images for %I, %Q and %M, so the
ST's behaviour can be compared with the reference interpreter's. It knows only the
subset the export writes (assignments, IF, WHILE, CASE, FOR, calls of the blocks, the
conversions and MIN/SHL/SHR/TIME) and the widths of BOOL, BYTE, WORD, INT, DINT and TIME.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass, field
from typing import Any

from lark import Lark, Token, Tree

GRAMMAR = r"""
start: (globals | pou)*
globals: "VAR_GLOBAL" decl* "END_VAR"
pou: KIND NAME locals? body END
body: stmt*
KIND: "PROGRAM" | "FUNCTION_BLOCK"
END: "END_PROGRAM" | "END_FUNCTION_BLOCK"
locals: "VAR" decl* "END_VAR"
decl: NAME ("AT" ADDRESS)? ":" type ";"
type: NAME | "ARRAY" "[" INT ".." INT "]" "OF" NAME -> array
?stmt: assign | if_ | while_ | case_ | for_ | call
assign: ref ":=" expr ";"
call: NAME "(" ")" ";"
if_: "IF" expr "THEN" body ("ELSE" body)? "END_IF" ";"
while_: "WHILE" expr "DO" body "END_WHILE" ";"
for_: "FOR" NAME ":=" expr "TO" expr "DO" body "END_FOR" ";"
case_: "CASE" expr "OF" branch* ("ELSE" body)? "END_CASE" ";"
branch: SIGNED ":" body
?expr: or_
?or_: and_ | or_ "OR" and_ -> bor
?and_: cmp | and_ "AND" cmp -> band
?cmp: sum | sum CMP sum -> compare
?sum: prod | sum ADD prod -> arith
?prod: unary | prod MUL unary -> arith
?unary: atom | "NOT" unary -> bnot | "-" unary -> neg
?atom: NUMBER -> number | "TRUE" -> true | "FALSE" -> false | ref
     | NAME "(" [expr ("," expr)*] ")" -> func | "(" expr ")"
ref: NAME ("[" expr "]")? ("." INT)?
CMP: "<>" | "<=" | ">=" | "=" | "<" | ">"
ADD: "+" | "-"
MUL: "*" | "/" | "MOD"
NUMBER: /16#[0-9A-Fa-f]+/ | /[0-9]+/
SIGNED: /-?[0-9]+/
ADDRESS: /%[IQM][XB][0-9.]+/
NAME: /(?!(END_|(OF|DO|THEN|ELSE|TO|AND|OR|NOT|MOD|AT|VAR)\b))[A-Za-z_][A-Za-z0-9_]*/
COMMENT: /\(\*.*?\*\)/s
%import common.INT
%import common.WS
%ignore WS
%ignore COMMENT
"""


@functools.cache
def _parser() -> Lark:
    """Built on first use: only the workers that run an ST test pay its 0.5 s."""
    return Lark(GRAMMAR, parser="lalr")


_WIDTH = {"BOOL": 1, "BYTE": 8, "WORD": 16, "INT": 16, "DINT": 32, "TIME": 32}
_SIGNED = {"INT", "DINT"}


def _fit(value: Any, kind: str) -> Any:
    """A value as a variable of the type holds it (wrapped, signed where signed)."""
    width = _WIDTH[kind]
    if width == 1:
        return bool(value)
    value = int(value) % (1 << width)
    return value - (1 << width) if kind in _SIGNED and value >> (width - 1) else value


class Stop(Exception):
    """A runaway loop."""


@dataclass
class Variable:
    type: str
    value: Any
    #: a located variable: (image, byte, bit or -1 for a byte)
    place: tuple[str, int, int] | None = None


@dataclass
class StMachine:
    text: str
    images: dict[str, bytearray] = field(default_factory=lambda: {
        "I": bytearray(16), "Q": bytearray(16), "M": bytearray(128)})
    clock_ms: int = 0

    def __post_init__(self) -> None:
        tree = _parser().parse(self.text)
        self.globals: dict[str, Variable] = {}
        self.pous: dict[str, Tree] = {}
        self.program = ""
        for item in tree.children:
            if item.data == "globals":
                for decl in item.children:
                    self._declare(self.globals, decl)
            else:
                kind, name = str(item.children[0]), str(item.children[1])
                self.pous[name] = item
                if kind == "PROGRAM":
                    self.program = name
        #: instance name -> the block it runs
        self.instances = {n: v.type for n, v in self.globals.items() if v.type in self.pous}
        self.frames: list[dict[str, Variable]] = []

    def _declare(self, scope: dict[str, Variable], decl: Tree) -> None:
        name = str(decl.children[0])
        address = next((str(c) for c in decl.children[1:] if isinstance(c, Token)
                        and c.type == "ADDRESS"), None)
        kind = decl.children[-1]
        if kind.data == "array":
            low, high, base = (str(c) for c in kind.children)
            scope[name] = Variable(base, [0] * (int(high) - int(low) + 1))
        else:
            scope[name] = Variable(str(kind.children[0]), 0)
        if address is not None:
            match = re.match(r"%([IQM])([XB])(\d+)(?:\.(\d+))?", address)
            assert match is not None
            bit = int(match[4]) if match[2] == "X" else -1
            scope[name].place = (match[1], int(match[3]), bit)

    # ------------------------------------------------------------------ running

    def cycle(self) -> None:
        self._run(self.pous[self.program])

    def _run(self, pou: Tree) -> None:
        local: dict[str, Variable] = {}
        parts = pou.children[2:-1]
        if parts[0].data == "locals":
            for decl in parts[0].children:
                self._declare(local, decl)
        self.frames.append(local)
        self._steps = 0
        try:
            self._block(parts[-1])
        finally:
            self.frames.pop()

    def _block(self, body: Tree | None) -> None:
        for statement in body.children if body is not None else ():
            self._statement(statement)

    def _statement(self, node: Tree) -> None:
        self._steps += 1
        if self._steps > 200_000:
            raise Stop("more than 200000 statements in one cycle")
        kind = node.data
        if kind == "assign":
            self._store(node.children[0], self._eval(node.children[1]))
        elif kind == "call":
            self._run(self.pous[self.instances[str(node.children[0])]])
        elif kind == "if_":
            condition, then, *other = node.children
            self._block(then if self._eval(condition) else (other[0] if other else None))
        elif kind == "while_":
            condition, body = node.children
            while self._eval(condition):
                self._block(body)
        elif kind == "for_":
            name, first, last, body = node.children
            for value in range(self._eval(first), self._eval(last) + 1):
                self._lookup(str(name)).value = value
                self._block(body)
        elif kind == "case_":
            selector, *branches = node.children
            value = self._eval(selector)
            for branch in branches:
                if branch is not None and branch.data == "branch":
                    if int(branch.children[0]) == value:
                        self._block(branch.children[1])
                        return
                elif branch is not None:
                    self._block(branch)
        else:
            raise AssertionError(kind)

    # ------------------------------------------------------------------ values

    def _lookup(self, name: str) -> Variable:
        return self.frames[-1].get(name) or self.globals[name]

    def _read(self, variable: Variable) -> Any:
        if variable.place is None:
            return variable.value
        image, byte, bit = variable.place
        if isinstance(variable.value, list):
            return list(self.images[image][byte:byte + len(variable.value)])
        data = self.images[image][byte]
        return bool(data >> bit & 1) if bit >= 0 else data

    def _store(self, ref: Tree, value: Any) -> None:
        name, index, bit = self._parts(ref)
        variable = self._lookup(name)
        if index is None and bit is None:
            if variable.place is not None:
                image, byte, place_bit = variable.place
                if place_bit >= 0:
                    mask = 1 << place_bit
                    data = self.images[image][byte]
                    self.images[image][byte] = data | mask if value else data & ~mask
                else:
                    self.images[image][byte] = int(value) & 0xFF
            else:
                variable.value = _fit(value, variable.type)
            return
        assert index is not None
        current = variable.value[index]
        if bit is not None:
            current = current | 1 << bit if value else current & ~(1 << bit)
        else:
            current = int(value)
        variable.value[index] = _fit(current, variable.type)

    def _parts(self, ref: Tree) -> tuple[str, int | None, int | None]:
        name = str(ref.children[0])
        index = bit = None
        for child in ref.children[1:]:
            if isinstance(child, Token) and child.type == "INT":
                bit = int(child)
            elif child is not None:
                index = self._eval(child)
        return name, index, bit

    def _eval(self, node: Any) -> Any:
        kind = node.data
        if kind == "number":
            text = str(node.children[0])
            return int(text[3:], 16) if text.startswith("16#") else int(text)
        if kind in ("true", "false"):
            return kind == "true"
        if kind == "ref":
            name, index, bit = self._parts(node)
            value = self._read(self._lookup(name))
            if index is not None:
                value = value[index]
            return bool(value >> bit & 1) if bit is not None else value
        if kind == "bnot":
            return not self._eval(node.children[0])
        if kind == "neg":
            return -self._eval(node.children[0])
        if kind in ("band", "bor"):
            a, b = self._eval(node.children[0]), self._eval(node.children[1])
            if isinstance(a, bool) and isinstance(b, bool):
                return (a and b) if kind == "band" else (a or b)
            return (int(a) & int(b)) if kind == "band" else (int(a) | int(b))
        if kind == "compare":
            a, op, b = self._eval(node.children[0]), str(node.children[1]), \
                self._eval(node.children[2])
            return {"=": a == b, "<>": a != b, "<": a < b, "<=": a <= b, ">": a > b,
                    ">=": a >= b}[op]
        if kind == "arith":
            a, op, b = self._eval(node.children[0]), str(node.children[1]), \
                self._eval(node.children[2])
            if op == "/":
                return int(a / b)
            if op == "MOD":
                return a - int(a / b) * b
            return {"+": a + b, "-": a - b, "*": a * b}[op]
        if kind == "func":
            name = str(node.children[0])
            args = [self._eval(c) for c in node.children[1:] if c is not None]
            return self._function(name, args)
        raise AssertionError(kind)

    def _function(self, name: str, args: list[Any]) -> Any:
        if name == "TIME":
            return self.clock_ms % (1 << 32)
        if name == "MIN":
            return min(args)
        if name == "SHL":
            return (args[0] << args[1]) & 0xFFFF
        if name == "SHR":
            return (args[0] & 0xFFFF) >> args[1]
        _, _, target = name.partition("_TO_")
        return _fit(args[0], target)
