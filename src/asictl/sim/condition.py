"""Conditions over operands: ``"Q 2.0 and not I 1.2"``, ``"CV 0 >= 3"``, ``"Motor == 1"``.

A plant model's ``rule`` fires on one (docs/simulation.md) and ``asictl.testing``'s
``run_until`` waits for one, so both read the same small language: operands as
``observe.operands`` reads them (symbols too), compared with a number (``==``, ``!=``,
``<``, ``<=``, ``>``, ``>=``) or alone (true when not 0), joined by ``and``, ``or``,
``not`` and parentheses. Errors are ``ValueError`` naming the part that is wrong.
"""

from __future__ import annotations

import operator
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from asictl.observe.operands import Operand, parse_operand, read_number
from asictl.observe.symbols import SymbolTable

_TOKEN = re.compile(r"(\(|\)|==|!=|<=|>=|<|>|\band\b|\bor\b|\bnot\b)", re.IGNORECASE)
_COMPARE: dict[str, Callable[[int, int], bool]] = {
    "==": operator.eq, "!=": operator.ne, "<": operator.lt, "<=": operator.le,
    ">": operator.gt, ">=": operator.ge,
}
#: Parentheses (and ``not``) nested deeper than this are refused, not a recursion error.
MAX_DEPTH = 32
#: How a condition reads an operand's value now.
Read = Callable[[Operand], int]
_Node = Callable[[Read], bool]


@dataclass(frozen=True)
class Condition:
    """A parsed condition: its text, the operands it reads, and how to evaluate it."""

    text: str
    operands: tuple[Operand, ...]
    _test: _Node

    def __call__(self, read: Read) -> bool:
        return self._test(read)

    def __str__(self) -> str:
        return self.text


def parse_condition(
    text: str, variables: Mapping[str, int] | None = None, symbols: SymbolTable | None = None
) -> Condition:
    """Read ``text``; ``variables`` and ``symbols`` as ``parse_operand`` takes them."""
    if not isinstance(text, str) or not text.strip():
        raise ValueError("a condition is a text such as 'Q 2.0 and not I 1.2'")
    tokens = [t.strip() for t in _TOKEN.split(text) if t.strip()]
    parser = _Parser(text, tokens, variables, symbols)
    node = parser.either()
    if parser.at < len(tokens):
        raise ValueError(f"condition '{text}': unexpected '{tokens[parser.at]}'")
    return Condition(text.strip(), tuple(parser.operands), node)


class _Parser:
    """Recursive descent: either := both ('or' both)*; both := single ('and' single)*;
    single := 'not' single | '(' either ')' | OPERAND [COMPARISON NUMBER]."""

    def __init__(self, text: str, tokens: list[str], variables: Mapping[str, int] | None,
                 symbols: SymbolTable | None) -> None:
        self.text = text
        self.tokens = tokens
        self.at = 0
        self.variables = variables
        self.symbols = symbols
        self.operands: list[Operand] = []
        self.depth = 0

    def peek(self) -> str:
        return self.tokens[self.at].lower() if self.at < len(self.tokens) else ""

    def take(self) -> str:
        if self.at >= len(self.tokens):
            raise ValueError(f"condition '{self.text}' ends too early")
        self.at += 1
        return self.tokens[self.at - 1]

    def either(self) -> _Node:
        parts = [self.both()]
        while self.peek() == "or":
            self.take()
            parts.append(self.both())
        if len(parts) == 1:
            return parts[0]
        return lambda read: any(part(read) for part in parts)

    def both(self) -> _Node:
        parts = [self.single()]
        while self.peek() == "and":
            self.take()
            parts.append(self.single())
        if len(parts) == 1:
            return parts[0]
        return lambda read: all(part(read) for part in parts)

    def single(self) -> _Node:
        token = self.take()
        word = token.lower()
        if word == "not":
            self.depth += 1
            if self.depth > MAX_DEPTH:
                raise ValueError(f"condition '{self.text[:40]}': 'not' nested more than "
                                 f"{MAX_DEPTH} deep")
            inner = self.single()
            self.depth -= 1
            return lambda read: not inner(read)
        if word == "(":
            self.depth += 1
            if self.depth > MAX_DEPTH:
                raise ValueError(f"condition '{self.text[:40]}': parentheses nested more "
                                 f"than {MAX_DEPTH} deep")
            inner = self.either()
            self.depth -= 1
            if self.take() != ")":
                raise ValueError(f"condition '{self.text}': ')' expected")
            return inner
        if word in ("and", "or", ")") or word in _COMPARE:
            raise ValueError(f"condition '{self.text}': an operand expected before '{token}'")
        operand = parse_operand(token, self.variables, self.symbols)
        self.operands.append(operand)
        if self.peek() in _COMPARE:
            compare = _COMPARE[self.take()]
            value = read_number(self.take())
            return lambda read: compare(read(operand), value)
        return lambda read: read(operand) != 0
