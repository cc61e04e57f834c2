"""Assembler expressions: parsing them from tokens and computing their values.

Precedence follows C and Intel ASM51 (``*`` over ``+`` over shifts over ``&`` over
``^`` over ``|``). as31 ranks differently: shifts over ``&`` and ``|`` (one level)
over ``*`` over ``+``, so ``2+3&1`` is 3 there and 1 here, and ``2|4&1`` is 0 there
and 2 here. Rather than pick one and silently miscompile sources written for the
other, an expression whose meaning differs between the two orders must be
parenthesised; everything both read the same way is accepted as written.

Values are bounded: every number and every intermediate result must fit in 32 bits
(``VALUE_LIMIT``), and one expression holds at most ``MAX_OPERATORS`` operators. Without
the bound, 25 lines of ``EQU`` that square each other make numbers of millions of bits and
the assembler never finishes; without the second, deep nesting exhausts Python's stack.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

from asictl.mcs51.asm_errors import AsmError, Code
from asictl.mcs51.asm_lexer import Token, TokenKind, parse_number
from asictl.mcs51.isa import bit_address, is_bit_addressable_byte
from asictl.mcs51.words import REGISTER_NAMES, UNARY_WORDS

#: Every value, final or intermediate, lies strictly between -VALUE_LIMIT and VALUE_LIMIT:
#: 32 bits, signed or unsigned, more than any 8051 operand needs.
VALUE_LIMIT = 1 << 32
#: Operators (parentheses and ``.`` included) one expression may hold.
MAX_OPERATORS = 64


def bounded(value: int, node: Expr) -> int:
    """``value`` if it fits in 32 bits, else an error at the expression that made it."""
    if -VALUE_LIMIT < value < VALUE_LIMIT:
        return value
    raise AsmError(
        "value out of range: more than 32 bits", node.column, node.length, Code.EXPRESSION
    )


class Undefined(AsmError):
    """A symbol with no value (yet): an error in the last pass, a retry before it."""

    def __init__(self, name: str, column: int) -> None:
        super().__init__(f"undefined symbol '{name}'", column, len(name), Code.UNDEFINED)
        self.name = name


@dataclass(frozen=True, slots=True)
class Env:
    """What an expression can see: symbol values and the location counter ``$``."""

    lookup: Callable[[str, int], int]  # (name, column) -> value, or raise Undefined
    here: int


@dataclass(frozen=True, slots=True)
class Expr:
    column: int
    length: int

    @property
    def end(self) -> int:
        return self.column + self.length

    def value(self, env: Env) -> int:
        raise NotImplementedError


@dataclass(frozen=True, slots=True)
class Number(Expr):
    number: int

    def value(self, env: Env) -> int:
        return self.number


@dataclass(frozen=True, slots=True)
class SymbolRef(Expr):
    name: str

    def value(self, env: Env) -> int:
        return env.lookup(self.name, self.column)


@dataclass(frozen=True, slots=True)
class Here(Expr):
    def value(self, env: Env) -> int:
        return env.here


@dataclass(frozen=True, slots=True)
class Unary(Expr):
    op: str
    operand: Expr

    def value(self, env: Env) -> int:
        v = self.operand.value(env)
        match self.op:
            case "-":
                return -v
            case "+":
                return v
            case "~":
                return bounded(~v, self)
            case "HIGH":
                return (v >> 8) & 0xFF
            case _:  # LOW
                return v & 0xFF


@dataclass(frozen=True, slots=True)
class Binary(Expr):
    op: str
    left: Expr
    right: Expr
    #: Written in parentheses, so it may be mixed with any operator.
    grouped: bool = False

    def value(self, env: Env) -> int:
        return bounded(self._compute(self.left.value(env), self.right.value(env)), self)

    def _compute(self, a: int, b: int) -> int:
        match self.op:
            case "+":
                return a + b
            case "-":
                return a - b
            case "*":
                return a * b
            case "/" | "%":
                if b == 0:
                    raise AsmError(
                        "division by zero", self.right.column, self.right.length, Code.EXPRESSION
                    )
                # C semantics (truncate towards zero), as as31 computes it
                quotient = abs(a) // abs(b) * (1 if (a < 0) == (b < 0) else -1)
                return quotient if self.op == "/" else a - quotient * b
            case "&":
                return a & b
            case "|":
                return a | b
            case "^":
                return a ^ b
            case _:  # << >>
                if not 0 <= b < 64:
                    raise AsmError(
                        f"shift count {b} out of range", self.right.column, code=Code.EXPRESSION
                    )
                return a << b if self.op == "<<" else a >> b


@dataclass(frozen=True, slots=True)
class BitSelect(Expr):
    """``byte.bit``: a bit of a bit-addressable byte, e.g. 20h.3 or ACC.7."""

    byte: Expr
    bit: Expr

    def value(self, env: Env) -> int:
        byte = self.byte.value(env)
        bit = self.bit.value(env)
        if not 0 <= bit <= 7:
            raise AsmError(
                f"bit number {bit} is not 0..7", self.bit.column, self.bit.length, Code.OUT_OF_RANGE
            )
        if not is_bit_addressable_byte(byte):
            raise AsmError(
                f"byte {format_hex(byte)} is not bit-addressable "
                "(20h..2Fh, or an SFR at a multiple of 8)",
                self.byte.column,
                self.byte.length,
                Code.NOT_BIT_ADDRESSABLE,
            )
        return bit_address(byte, bit)


def operator_count(expr: Expr) -> int:
    """How deep an expression's evaluation nests (its operators, an upper bound)."""
    match expr:
        case Unary(operand=operand):
            return 1 + operator_count(operand)
        case Binary(left=left, right=right):
            return 1 + operator_count(left) + operator_count(right)
        case BitSelect(byte=byte, bit=bit):
            return 1 + operator_count(byte) + operator_count(bit)
        case _:
            return 0


def symbol_names(expr: Expr) -> Iterator[str]:
    """The names of the symbols an expression refers to, as written."""
    match expr:
        case SymbolRef(name=name):
            yield name
        case Unary(operand=operand):
            yield from symbol_names(operand)
        case Binary(left=left, right=right):
            yield from symbol_names(left)
            yield from symbol_names(right)
        case BitSelect(byte=byte, bit=bit):
            yield from symbol_names(byte)
            yield from symbol_names(bit)
        case _:
            pass


def format_hex(value: int, width: int = 1) -> str:
    """A value the way ASM51 writes hex, at least ``width`` digits: 0FFh, 20h, 0012h."""
    if value < 0 or (value < 10 and width == 1):
        return str(value)
    digits = f"{value:0{width}X}"
    return f"{'0' if digits[0] in 'ABCDEF' else ''}{digits}h"


_PRECEDENCE = {"|": 1, "^": 2, "&": 3, "<<": 4, ">>": 4, "+": 5, "-": 5, "*": 6, "/": 6, "%": 6}
#: as31's order (``^`` is ours only; it joins ``&`` and ``|`` so mixing needs parentheses).
_AS31_PRECEDENCE = {
    "+": 1,
    "-": 1,
    "*": 2,
    "/": 2,
    "%": 2,
    "&": 3,
    "|": 3,
    "^": 3,
    "<<": 4,
    ">>": 4,
}


class ExprParser:
    """A precedence-climbing parser over one line's tokens, starting at ``pos``."""

    def __init__(self, tokens: list[Token], pos: int, end_column: int) -> None:
        self.tokens = tokens
        self.pos = pos
        #: Column just past the line's text, for "expected a value" at the end.
        self.end_column = end_column
        self.operators = 0

    def _count_operator(self, token: Token) -> None:
        """Stop before nesting gets deep enough to exhaust the stack (``MAX_OPERATORS``)."""
        self.operators += 1
        if self.operators > MAX_OPERATORS:
            raise AsmError(
                f"expression too complex: more than {MAX_OPERATORS} operators; "
                "split it with EQU",
                token.column,
                len(token.text),
                Code.EXPRESSION,
            )

    def peek(self) -> Token | None:
        return self.tokens[self.pos] if self.pos < len(self.tokens) else None

    def peek_punct(self) -> str | None:
        tok = self.peek()
        return tok.text if tok is not None and tok.kind is TokenKind.PUNCT else None

    def parse(self, min_precedence: int = 0) -> Expr:
        left = self._unary()
        while True:
            op = self.peek_punct()
            if op is None or (precedence := _PRECEDENCE.get(op, 0)) <= min_precedence:
                return left
            op_token = self.tokens[self.pos]
            self._count_operator(op_token)
            self.pos += 1
            right = self.parse(precedence)
            self._check_as31_agrees(op, op_token, left, right)
            left = Binary(left.column, right.end - left.column, op, left, right)

    @staticmethod
    def _check_as31_agrees(op: str, op_token: Token, left: Expr, right: Expr) -> None:
        """Reject ``left op right`` if as31's precedence would group it differently."""
        level = _AS31_PRECEDENCE[op]
        for child, tighter in ((left, False), (right, True)):
            if not isinstance(child, Binary) or child.grouped:
                continue
            child_level = _AS31_PRECEDENCE[child.op]
            if child_level < level or (tighter and child_level == level):
                raise AsmError(
                    f"add parentheses: as31 and ASM51 group '{child.op}' and '{op}' differently",
                    op_token.column,
                    len(op),
                    Code.AMBIGUOUS_PRECEDENCE,
                )

    def _unary(self) -> Expr:
        tok = self.peek()
        if tok is not None and (
            (tok.kind is TokenKind.PUNCT and tok.text in "-+~")
            or (tok.kind is TokenKind.IDENT and tok.text.upper() in UNARY_WORDS)
        ):
            self._count_operator(tok)
            self.pos += 1
            operand = self._unary()
            op = tok.text.upper()
            return Unary(tok.column, operand.end - tok.column, op, operand)
        return self._postfix()

    def _postfix(self) -> Expr:
        node = self._primary()
        while self.peek_punct() == ".":
            self._count_operator(self.tokens[self.pos])
            self.pos += 1
            bit = self._primary()
            node = BitSelect(node.column, bit.end - node.column, node, bit)
        return node

    def _primary(self) -> Expr:
        tok = self.peek()
        if tok is None:
            raise AsmError("expected a value", self.end_column)
        self.pos += 1
        if tok.kind is TokenKind.NUMBER:
            try:
                return Number(tok.column, len(tok.text), parse_number(tok.text))
            except ValueError as exc:
                raise AsmError(str(exc), tok.column, len(tok.text)) from None
        if tok.kind is TokenKind.STRING:
            return Number(tok.column, len(tok.text), char_constant(tok))
        if tok.kind is TokenKind.IDENT:
            if tok.text.upper() in REGISTER_NAMES:
                raise AsmError(
                    f"register {tok.text.upper()} cannot be used in an expression",
                    tok.column,
                    len(tok.text),
                )
            return SymbolRef(tok.column, len(tok.text), tok.text)
        if tok.text in ("$", "*"):
            return Here(tok.column, 1)
        if tok.text == "(":
            self._count_operator(tok)
            inner = self.parse()
            close = self.peek()
            if close is None or close.text != ")":
                raise AsmError("missing ')'", close.column if close else self.end_column)
            self.pos += 1
            length = close.column + 1 - tok.column
            if isinstance(inner, Binary):
                return Binary(tok.column, length, inner.op, inner.left, inner.right, True)
            return inner
        raise AsmError(f"expected a value, found '{tok.text}'", tok.column, len(tok.text))


def char_constant(tok: Token) -> int:
    """'A' is 41h; two characters 'AB' make a 16-bit value, high byte first (ASM51)."""
    chars = tok.value
    if not 1 <= len(chars) <= 2:
        raise AsmError("a character constant has one or two characters", tok.column, len(tok.text))
    value = 0
    for char in chars:
        if ord(char) > 0xFF:
            raise AsmError(f"character {char!r} does not fit in a byte", tok.column, len(tok.text))
        value = value << 8 | ord(char)
    return value
