"""Conditions over operands, one language for every tool: ``"Q 2.0 and not I 1.2"``,
``"CV 0 >= 3"``, ``"TV 1 >= 2s"``, ``"(Start or Jog) xor Stop"``.

A plant model's ``rule`` fires on one, ``asictl.testing``'s ``run_until`` waits for one, a
properties file states its properties and ``[assume]`` in them, and the debugger and the
editors' conditional breakpoints stop on one. docs/conditions.md is the language's one
description.

The grammar is ``grammar/condition.lark`` (lark, LALR). ``parse_condition`` reads a text
into a small tree of frozen dataclasses (``Expr``) whose nodes keep where they stand in
the text; a ``Condition`` evaluates it on concrete values, ``show`` writes it back, and
the prover translates the same tree into its terms (``prove/engine.py``). Every mistake
is a ``ConditionError`` with the offset and length of the offending part, which each
host turns into its own position (a file's line and column, a caret under a command).

Why the limits (``MAX_DEPTH``, ``MAX_LENGTH``): a condition is written by hand; anything
nested deeper or longer is a mistake or an attack, and refusing it plainly at a position
is better than a ``RecursionError`` in whichever host met it first.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Callable, Collection, Iterator, Mapping
from dataclasses import dataclass, field
from importlib.resources import files
from typing import assert_never

import lark

from asictl.files import grammar_cache
from asictl.il import ast
from asictl.observe.operands import Operand, parse_operand, read_number
from asictl.observe.symbols import SymbolTable
from asictl.readers.suggest import did_you_mean
from asictl.readers.units import parse_duration

#: Parentheses and ``not`` nested deeper than this are refused.
MAX_DEPTH = 32
#: Longer conditions are refused (this also bounds the number of terms).
MAX_LENGTH = 4000
#: The largest number or duration (ms): the prover computes on 32 bits.
MAX_NUMBER = 0xFFFF_FFFF
#: How a condition reads an operand's value now.
Read = Callable[[Operand], int]
#: How the debugger's conditions read a register (RLO, ACCU1 ...) by name.
ReadRegister = Callable[[str], int]
COMPARISONS: dict[str, Callable[[int, int], bool]] = {
    "==": operator.eq, "!=": operator.ne, "<": operator.lt, "<=": operator.le,
    ">": operator.gt, ">=": operator.ge,
}
_KEYWORDS = ("and", "or", "xor", "not", "true", "false")
EXAMPLE = "Q 2.0 and not I 1.2"


class ConditionError(ValueError):
    """A condition that cannot be read: the message, and where in the text (``offset``,
    ``length`` in characters) the offending part stands."""

    def __init__(self, message: str, offset: int = 0, length: int = 1) -> None:
        super().__init__(message)
        self.message = message
        self.offset = offset
        self.length = max(1, length)

    def caret(self, text: str, indent: str = "  ") -> list[str]:
        """``text`` and a caret line under the offending part, as the debugger shows them."""
        line = text.replace("\n", " ")
        return [indent + line, indent + " " * self.offset + "^" + "~" * (self.length - 1)]


# ---------------------------------------------------------------------- the tree


@dataclass(frozen=True)
class Ref:
    """An operand or symbol, as written."""

    text: str
    operand: Operand
    offset: int = field(default=0, compare=False)


@dataclass(frozen=True)
class Register:
    """One of the IL machine's registers (RLO, ACCU1 ...), in the debugger's conditions."""

    name: str
    is_bit: bool
    offset: int = field(default=0, compare=False)


@dataclass(frozen=True)
class Number:
    value: int
    offset: int = field(default=0, compare=False)


@dataclass(frozen=True)
class Duration:
    """A time with its unit (``2s``), in whole milliseconds: what ``TV n`` holds."""

    ms: int
    offset: int = field(default=0, compare=False)


@dataclass(frozen=True)
class Truth:
    value: bool
    offset: int = field(default=0, compare=False)


@dataclass(frozen=True)
class Negation:
    arg: Expr
    offset: int = field(default=0, compare=False)


@dataclass(frozen=True)
class Connective:
    """``and``, ``or`` or ``xor`` of two or more conditions (``xor``: an odd number hold)."""

    op: str
    parts: tuple[Expr, ...]
    offset: int = field(default=0, compare=False)


@dataclass(frozen=True)
class Comparison:
    """``== != < <= > >=`` of two values, or ``==``/``!=`` of two conditions."""

    op: str
    left: Expr
    right: Expr
    offset: int = field(default=0, compare=False)


Expr = Ref | Register | Number | Duration | Truth | Negation | Connective | Comparison
Value = Ref | Register | Number | Duration


def is_condition(expr: Expr) -> bool:
    """True or false (a bit, a comparison, a combination of them), not a value."""
    match expr:
        case Ref():
            return expr.operand.is_bit
        case Register():
            return expr.is_bit
        case Number() | Duration():
            return False
        case Truth() | Negation() | Connective() | Comparison():
            return True
        case _:
            assert_never(expr)


def refs(expr: Expr) -> Iterator[Ref]:
    """The operands an expression reads, in order."""
    match expr:
        case Ref():
            yield expr
        case Register() | Number() | Duration() | Truth():
            pass
        case Negation(arg=arg):
            yield from refs(arg)
        case Connective(parts=parts):
            for part in parts:
                yield from refs(part)
        case Comparison(left=left, right=right):
            yield from refs(left)
            yield from refs(right)
        case _:
            assert_never(expr)


# ---------------------------------------------------------------------- writing back

_BINDING = {"or": 1, "xor": 2, "and": 3}
_NOT, _COMPARISON, _ATOM = 4, 5, 6


def _binding(expr: Expr) -> int:
    match expr:
        case Connective(op=op):
            return _BINDING[op]
        case Negation():
            return _NOT
        case Comparison():
            return _COMPARISON
        case _:
            return _ATOM


def show(expr: Expr, naming: Callable[[Ref], str] | None = None) -> str:
    """The expression written back, with the parentheses its structure needs (so that
    reading it again gives the same tree); ``naming`` shows each operand (default: as
    written)."""
    def inner(part: Expr, above: int) -> str:
        text = show(part, naming)
        return f"({text})" if _binding(part) <= above else text

    match expr:
        case Ref(text=text):
            return text if naming is None else naming(expr)
        case Register(name=name):
            return name
        case Number(value=value):
            return str(value)
        case Duration(ms=ms):
            return f"{ms}ms"
        case Truth(value=value):
            return "true" if value else "false"
        case Negation(arg=arg):
            return f"not {inner(arg, _NOT - 1)}"
        case Connective(op=op, parts=parts):
            return f" {op} ".join(inner(part, _BINDING[op]) for part in parts)
        case Comparison(op=op, left=left, right=right):
            return f"{inner(left, _COMPARISON)} {op} {inner(right, _COMPARISON)}"
        case _:
            assert_never(expr)


# ---------------------------------------------------------------------- evaluating


@dataclass(frozen=True)
class Condition:
    """A parsed condition: its text, its tree, and the operands it reads."""

    text: str
    expr: Expr

    @functools.cached_property
    def operands(self) -> tuple[Operand, ...]:
        return tuple(dict.fromkeys(ref.operand for ref in refs(self.expr)))

    def __call__(self, read: Read, registers: ReadRegister | None = None) -> bool:
        """Whether it holds with the values ``read`` (and ``registers``) give."""
        return holds(self.expr, read, registers)

    def __str__(self) -> str:
        return self.text


def holds(expr: Expr, read: Read, registers: ReadRegister | None = None) -> bool:
    """The concrete evaluator: ``expr`` (a condition) on the values ``read`` gives."""
    match expr:
        case Ref() | Register():
            return value_of(expr, read, registers) != 0
        case Truth(value=truth):
            return truth
        case Negation(arg=arg):
            return not holds(arg, read, registers)
        case Connective(op="and", parts=parts):
            return all(holds(part, read, registers) for part in parts)
        case Connective(op="or", parts=parts):
            return any(holds(part, read, registers) for part in parts)
        case Connective(parts=parts):  # xor
            return sum(holds(part, read, registers) for part in parts) % 2 == 1
        case Comparison(op="==" | "!=" as op, left=left, right=right) if is_condition(
                left) and is_condition(right):
            return COMPARISONS[op](holds(left, read, registers), holds(right, read, registers))
        case Comparison(op=op, left=left, right=right):
            return COMPARISONS[op](value_of(left, read, registers),
                                  value_of(right, read, registers))
        case Number() | Duration():
            raise AssertionError("a number is no condition (parse_condition refuses it)")
        case _:
            assert_never(expr)


def value_of(expr: Expr, read: Read, registers: ReadRegister | None = None) -> int:
    """The value of an operand, register, number or duration (a bit is 0 or 1)."""
    match expr:
        case Ref(operand=operand):
            return read(operand)
        case Register(name=name):
            assert registers is not None, "a register is read only where registers are named"
            return registers(name)
        case Number(value=number):
            return number
        case Duration(ms=ms):
            return ms
        case _:
            return int(holds(expr, read, registers))


# ---------------------------------------------------------------------- reading


@functools.cache
def _parser() -> lark.Lark:
    grammar = files("asictl").joinpath("grammar/condition.lark").read_text(encoding="utf-8")
    return lark.Lark(grammar, parser="lalr", lexer="contextual", propagate_positions=True,
                     cache=grammar_cache("condition"))


def parse_condition(
    text: str,
    variables: Mapping[str, int] | None = None,
    symbols: SymbolTable | None = None,
    *,
    registers: Mapping[str, bool] | None = None,
) -> Condition:
    """Read ``text``; ``variables`` and ``symbols`` as ``parse_operand`` takes them,
    ``registers`` the register names the host reads (name -> whether it is a bit).
    ``ConditionError`` says what is wrong and where."""
    return Condition(text, parse_expression(text, variables, symbols, registers=registers))


def parse_expression(
    text: str,
    variables: Mapping[str, int] | None = None,
    symbols: SymbolTable | None = None,
    *,
    registers: Mapping[str, bool] | None = None,
    condition: bool = True,
) -> Expr:
    """The tree of ``text``; with ``condition``, refused unless it is true or false."""
    if not isinstance(text, str) or not text.strip():
        raise ConditionError(f"a condition is a text such as '{EXAMPLE}'", 0,
                             len(text) if isinstance(text, str) else 1)
    if len(text) > MAX_LENGTH:
        raise ConditionError(f"a condition has at most {MAX_LENGTH} characters, this one "
                             f"{len(text)}", MAX_LENGTH)
    bad = next((i for i, c in enumerate(text) if c in "\r\n\0"), None)
    if bad is not None:
        raise ConditionError("a condition is one line", bad)
    try:
        tree = _parser().parse(text)
    except lark.UnexpectedCharacters as exc:
        at = exc.pos_in_stream or 0
        raise ConditionError(f"unexpected character '{text[at]}'", at) from None
    except lark.UnexpectedToken as exc:
        raise _unexpected(text, exc) from None
    builder = _Builder(text, variables, symbols, registers or {})
    expr = builder.build(tree, 0)
    if condition and not is_condition(expr):
        raise ConditionError(f"a condition is true or false: compare the value {show(expr)} "
                             f"(such as {show(expr)} != 0)", 0, len(text.rstrip()))
    return expr


def _unexpected(text: str, exc: lark.UnexpectedToken) -> ConditionError:
    token = exc.token
    at_end = token.type == "$END"
    offset = len(text.rstrip()) if at_end else token.start_pos or 0
    found = "the end" if at_end else f"'{token}'"
    if token.type == "COMPARE" and "COMPARE" not in exc.expected:
        return ConditionError("comparisons do not chain: combine them with 'and'", offset,
                              len(token))
    return ConditionError(f"expected {_expected(exc.expected)}, found {found}", offset,
                          1 if at_end else len(token))


def _expected(terminals: Collection[str]) -> str:
    """What may stand where the parser stopped, in words: an operand (where one starts),
    else what may follow one (LALR's sets are per state, so and/or/xor are always named)."""
    if {"NOT", "LPAR", "TRUE"} & set(terminals) and "COMPARE" not in terminals:
        return "an operand, a number or '('"
    words = ["and", "or", "xor"] + [word for name, word in (
        ("COMPARE", "a comparison"), ("RPAR", "')'"), ("$END", "the end")) if name in terminals]
    return ", ".join(words[:-1]) + " or " + words[-1]


class _Builder:
    """The parse tree to ``Expr``, checking how values and conditions combine. Recursion
    stops at ``MAX_DEPTH``: deeper trees are refused before they are walked."""

    def __init__(self, text: str, variables: Mapping[str, int] | None,
                 symbols: SymbolTable | None, registers: Mapping[str, bool]) -> None:
        self.text = text
        self.variables = variables
        self.symbols = symbols
        self.registers = {name.upper(): bit for name, bit in registers.items()}
        #: id of a node built -> its length in the text (the nodes live while they are built)
        self.spans: dict[int, int] = {}

    def build(self, tree: lark.Tree[lark.Token], depth: int) -> Expr:
        expr = self.node(tree, depth)
        self.spans.setdefault(id(expr), tree.meta.end_pos - tree.meta.start_pos)
        return expr

    def node(self, tree: lark.Tree[lark.Token], depth: int) -> Expr:
        offset = tree.meta.start_pos
        rule = str(tree.data)
        if rule in ("negation", "group"):
            depth += 1
            if depth > MAX_DEPTH:
                what = "'not'" if rule == "negation" else "parentheses"
                raise ConditionError(f"{what} nested more than {MAX_DEPTH} deep", offset)
        if rule == "value":
            return self.value(tree)
        if rule == "truth":
            return Truth(str(tree.children[0]).lower() == "true", offset)
        subtrees = [child for child in tree.children if not isinstance(child, lark.Token)]
        parts = [self.build(child, depth) for child in subtrees]
        if rule == "group":
            return parts[0]
        if rule == "negation":
            self.need_condition(parts[0], "'not' negates a condition, not the value")
            return Negation(parts[0], offset)
        if rule == "comparison":
            return self.comparison(tree, parts)
        op = {"either": "or", "other": "xor", "both": "and"}[rule]
        for part in parts:
            self.need_condition(part, f"'{op}' combines conditions: compare the value")
        return Connective(op, tuple(parts), offset)

    def need_condition(self, expr: Expr, message: str) -> None:
        if not is_condition(expr):
            raise ConditionError(f"{message} {show(expr)} (such as {show(expr)} != 0)",
                                 expr.offset, self.length(expr))

    def length(self, expr: Expr) -> int:
        """Characters of ``expr`` in the text, for a caret under all of it."""
        return self.spans.get(id(expr), 1)

    def comparison(self, tree: lark.Tree[lark.Token], parts: list[Expr]) -> Comparison:
        token = next(c for c in tree.children if isinstance(c, lark.Token))
        op = "==" if str(token) == "=" else str(token)
        left, right = parts
        if op in ("==", "!=") and is_condition(left) and is_condition(right):
            return Comparison(op, left, right, tree.meta.start_pos)
        for side in (left, right):
            if isinstance(side, Truth | Negation | Connective | Comparison):
                raise ConditionError(f"'{op}' compares values (operands and numbers), not "
                                     f"{show(side)}", side.offset, self.length(side))
        for side, other in ((left, right), (right, left)):
            if isinstance(side, Duration) and not _is_timer_value(other):
                written = self.text[side.offset:side.offset + self.length(side)]
                hint = (f" ('{written}' is {written[:-1]} hours: a number in hex is written "
                        f"0x{written[:-1]})" if written[-1:] in "hH" and written[:-1].isdigit()
                        else "")
                raise ConditionError(f"a duration compares with a timer's value (TV n), not "
                                     f"{show(other)}{hint}", side.offset, self.length(side))
        return Comparison(op, left, right, tree.meta.start_pos)

    def value(self, tree: lark.Tree[lark.Token]) -> Value:
        words = [c for c in tree.children if isinstance(c, lark.Token)]
        for index, word in enumerate(words):
            if str(word).lower() in _KEYWORDS:
                found = f"'{word}'"
                message = (f"expected an operand, a number or '(', found {found}" if index == 0
                           else f"expected and, or, xor, a comparison or the end, found {found}")
                raise ConditionError(message, word.start_pos or 0, len(word))
        start = words[0].start_pos or 0
        end = words[-1].end_pos or len(self.text)
        written = self.text[start:end]
        if written.upper() in self.registers:
            return Register(written.upper(), self.registers[written.upper()], start)
        if written[0].isdigit():
            return self.number(written, start)
        try:
            return Ref(written, parse_operand(written, self.variables, self.symbols), start)
        except ValueError as exc:
            names = [name for name, _ in self.symbols.entries.values()] if self.symbols else []
            raise ConditionError(str(exc) + did_you_mean(written, names), start,
                                 len(written)) from None

    def number(self, written: str, start: int) -> Number | Duration:
        """``12``, ``0x0C``, ``0b1100`` (and the IL's ``0Ch``), or a duration (``2s``):
        what reads as a duration with a unit is one, so ``2h`` is two hours."""
        try:
            ms = parse_duration(written)
        except ValueError:
            ms = None
        if ms is not None and not written.strip().isdigit():
            if ms != int(ms) or ms > MAX_NUMBER:
                raise ConditionError(f"'{written}': a duration in whole milliseconds up to "
                                     f"{MAX_NUMBER}", start, len(written))
            return Duration(int(ms), start)
        try:
            number = read_number(written)
        except ValueError as exc:
            raise ConditionError(f"{exc} or a duration (such as 2s)", start,
                                 len(written)) from None
        if number > MAX_NUMBER:
            raise ConditionError(f"'{written}': a number up to {MAX_NUMBER}", start, len(written))
        return Number(number, start)


def _is_timer_value(expr: Expr) -> bool:
    """``TV n``: a timer's remaining time in milliseconds, what a duration compares with."""
    if not isinstance(expr, Ref):
        return False
    node = expr.operand.node
    return node.kind is ast.OperandKind.T and node.width is ast.Width.WORD
