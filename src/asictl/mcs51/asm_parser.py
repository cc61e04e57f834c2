"""Reading one line of 8051 assembly into a statement, independent of any pass.

Each source line is parsed exactly once; the passes then only evaluate. The parser
accepts Intel ASM51 spelling (``ORG``, ``DB``, ``NAME EQU 5``) and the as31 dialect
(``.org``, ``.byte``, ``.equ NAME, 5``) side by side, mapping both onto one set of
statements so that nothing downstream knows which dialect a line was written in.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from enum import Enum

from asictl.mcs51.asm_errors import AsmError, Code
from asictl.mcs51.asm_expr import Expr, ExprParser, symbol_names
from asictl.mcs51.asm_lexer import Token, TokenKind, tokenize
from asictl.mcs51.isa import Operand
from asictl.mcs51.words import DEFINITION_WORDS, DIRECTIVES, MNEMONICS, RESERVED


class Shape(Enum):
    """What an operand looks like, before the instruction decides what it means."""

    REGISTER = "register"  # A, R3, @DPTR, ... (the Operand is known)
    IMMEDIATE = "#value"
    NOT_BIT = "/bit"
    VALUE = "value"  # a direct address, bit, or jump target: the mnemonic decides


@dataclass(frozen=True, slots=True)
class ParsedOperand:
    shape: Shape
    column: int
    length: int
    register: Operand | None = None
    expr: Expr | None = None
    text: str = ""


@dataclass(frozen=True, slots=True)
class Instruction:
    mnemonic: str  # upper case
    column: int
    operands: tuple[ParsedOperand, ...]


@dataclass(frozen=True, slots=True)
class DataString:
    """A quoted string in DB: one byte per character."""

    data: bytes
    column: int
    length: int


@dataclass(frozen=True, slots=True)
class Directive:
    name: str  # canonical: ORG, DB, DW, DS, END, INCLUDE, CONTROL
    column: int
    args: tuple[Expr | DataString, ...] = ()
    #: The file name of INCLUDE, or the text of an ignored $control line.
    text: str = ""


@dataclass(frozen=True, slots=True)
class Definition:
    """``NAME EQU value`` and its relatives: a symbol that is not a label."""

    name: str
    column: int
    kind: str  # EQU, SET, BIT, DATA, IDATA, XDATA, CODE
    expr: Expr


Statement = Instruction | Directive | Definition


@dataclass(frozen=True, slots=True)
class Label:
    name: str
    column: int


@dataclass(frozen=True, slots=True)
class ParsedLine:
    label: Label | None
    statement: Statement | None
    #: Why the statement could not be read; the label is still defined, so that one
    #: mistake does not also make every reference to the label an error.
    error: AsmError | None = None


#: as31's definition directives: .equ NAME, value and .flag NAME, bit.
_AS31_DEFINITIONS = {".EQU": "EQU", ".FLAG": "BIT"}

_REGISTERS = {
    "A": Operand.A,
    "AB": Operand.AB,
    "C": Operand.C,
    "DPTR": Operand.DPTR,
    **{f"R{i}": Operand[f"R{i}"] for i in range(8)},
}
_INDIRECT = {
    "R0": Operand.AT_R0,
    "R1": Operand.AT_R1,
    "DPTR": Operand.AT_DPTR,
    "A+DPTR": Operand.AT_A_DPTR,
    "DPTR+A": Operand.AT_A_DPTR,
    "A+PC": Operand.AT_A_PC,
    "PC+A": Operand.AT_A_PC,
}


def referenced_symbols(line: ParsedLine) -> Iterator[str]:
    """The names of the symbols a line's statement refers to (not the label it defines)."""
    statement = line.statement
    if isinstance(statement, Instruction):
        expressions: Iterable[Expr | DataString | None] = (op.expr for op in statement.operands)
    elif isinstance(statement, Directive):
        expressions = statement.args
    elif isinstance(statement, Definition):
        expressions = (statement.expr,)
    else:
        expressions = ()
    for expr in expressions:
        if isinstance(expr, Expr):
            yield from symbol_names(expr)


def parse_line(text: str) -> ParsedLine:
    """Parse one line (without its line end); problems are returned in ``error``."""
    if text.startswith("$"):
        return ParsedLine(None, _control(text))
    try:
        tokens = tokenize(text)
    except AsmError as exc:
        return ParsedLine(None, None, exc)
    return _LineParser(text, tokens).parse()


def _control(text: str) -> Directive:
    """An ASM51 ``$`` control line; only $INCLUDE(file) changes what is assembled."""
    body = text[1:].split(";", 1)[0].strip()
    if body.upper().startswith("INCLUDE"):
        name = body[len("INCLUDE") :].strip().removeprefix("(").removesuffix(")").strip()
        return Directive("INCLUDE", 1, text=name)
    return Directive("CONTROL", 1, text=body)


class _LineParser:
    def __init__(self, text: str, tokens: list[Token]) -> None:
        self.text = text
        self.tokens = tokens
        self.pos = 0
        self.end_column = len(text.rstrip()) + 1

    def parse(self) -> ParsedLine:
        toks = self.tokens
        label = None
        if len(toks) >= 2 and toks[0].kind is TokenKind.IDENT and toks[1].text == ":":
            try:
                self._check_name(toks[0])
            except AsmError as exc:
                return ParsedLine(None, None, exc)
            label = Label(toks[0].text, toks[0].column)
            self.pos = 2
        if self.pos >= len(toks):
            return ParsedLine(label, None)
        try:
            return ParsedLine(label, self._statement())
        except AsmError as exc:
            return ParsedLine(label, None, exc)

    def _statement(self) -> Statement:
        tok = self.tokens[self.pos]
        nxt = self.tokens[self.pos + 1] if self.pos + 1 < len(self.tokens) else None
        if tok.text == "." and nxt is not None and nxt.kind is TokenKind.IDENT:
            self.pos += 2
            return self._directive("." + nxt.text.upper(), tok.column, nxt.column + len(nxt.text))
        if tok.kind is not TokenKind.IDENT:
            raise AsmError(
                f"expected a mnemonic or directive, found '{tok.text}'", tok.column, len(tok.text)
            )
        word = tok.text.upper()
        self.pos += 1
        if word in MNEMONICS or word == "CALL":
            return Instruction(word, tok.column, self._operands())
        if word in DIRECTIVES:
            return self._directive(word, tok.column, tok.column + len(tok.text))
        if nxt is not None and nxt.kind is TokenKind.IDENT and nxt.text.upper() in DEFINITION_WORDS:
            self._check_name(tok)
            self.pos += 1
            return Definition(tok.text, tok.column, nxt.text.upper(), self._expr_to_end())
        if nxt is not None and nxt.text == ":":
            raise AsmError(f"'{tok.text}' is reserved", tok.column, len(tok.text))
        raise AsmError(
            f"unknown mnemonic '{tok.text}'", tok.column, len(tok.text), Code.UNKNOWN_MNEMONIC
        )

    def _directive(self, word: str, column: int, end: int) -> Directive | Definition:
        if word in _AS31_DEFINITIONS:
            name = self._take(TokenKind.IDENT, f"{word.lower()} needs a symbol name")
            self._check_name(name)
            self._take_punct(",", f"expected ',' after '{name.text}'")
            return Definition(name.text, name.column, _AS31_DEFINITIONS[word], self._expr_to_end())
        canonical = DIRECTIVES.get(word)
        if canonical is None:
            raise AsmError(
                f"unknown directive '{word.lower()}'", column, end - column, Code.UNKNOWN_MNEMONIC
            )
        if canonical == "INCLUDE":
            file = self.text[end - 1 :].split(";", 1)[0].strip().strip("\"'")
            if not file:
                raise AsmError("include needs a file name", column, end - column)
            return Directive("INCLUDE", column, text=file)
        if canonical == "END":
            self._expect_end()
            return Directive("END", column)
        if canonical in ("ORG", "DS"):
            return Directive(canonical, column, (self._expr_to_end(),))
        items = tuple(self._data_item(group) for group in self._groups())
        if not items:
            raise AsmError(f"{canonical} needs at least one value", column, end - column)
        return Directive(canonical, column, items)

    def _data_item(self, group: tuple[int, int]) -> Expr | DataString:
        start, stop = group
        tok = self.tokens[start]
        if (
            stop == start + 1
            and tok.kind is TokenKind.STRING
            and (tok.text[0] == '"' or len(tok.value) != 1)
        ):
            try:
                data = tok.value.encode("latin-1")
            except UnicodeEncodeError:
                raise AsmError(
                    "string has a character that does not fit in a byte", tok.column, len(tok.text)
                ) from None
            return DataString(data, tok.column, len(tok.text))
        return self._expr(start, stop)

    def _operands(self) -> tuple[ParsedOperand, ...]:
        return tuple(self._operand(*group) for group in self._groups())

    def _operand(self, start: int, stop: int) -> ParsedOperand:
        toks = self.tokens
        first, last = toks[start], toks[stop - 1]
        column, length = first.column, last.column + len(last.text) - first.column
        text = self.text[column - 1 : column - 1 + length]
        word = first.text.upper()
        if first.text == "#":
            return ParsedOperand(
                Shape.IMMEDIATE, column, length, expr=self._expr(start + 1, stop), text=text
            )
        if first.text in ("/", "!"):
            return ParsedOperand(
                Shape.NOT_BIT, column, length, expr=self._expr(start + 1, stop), text=text
            )
        if first.text == "@":
            inner = "".join(t.text.upper() for t in toks[start + 1 : stop])
            if inner not in _INDIRECT:
                raise AsmError(f"invalid indirect operand '{text}'", column, length)
            return ParsedOperand(
                Shape.REGISTER, column, length, register=_INDIRECT[inner], text=text
            )
        if stop == start + 1 and first.kind is TokenKind.IDENT and word in _REGISTERS:
            return ParsedOperand(
                Shape.REGISTER, column, length, register=_REGISTERS[word], text=text
            )
        return ParsedOperand(Shape.VALUE, column, length, expr=self._expr(start, stop), text=text)

    def _groups(self) -> list[tuple[int, int]]:
        """Token ranges of the comma-separated operands from ``pos`` to the line end."""
        groups: list[tuple[int, int]] = []
        depth = 0
        start = self.pos
        toks = self.tokens
        for i in range(self.pos, len(toks)):
            text = toks[i].text if toks[i].kind is TokenKind.PUNCT else ""
            if text == "(":
                depth += 1
            elif text == ")":
                depth -= 1
            elif text == "," and depth == 0:
                if i == start:
                    raise AsmError("missing operand before ','", toks[i].column)
                groups.append((start, i))
                start = i + 1
        if start < len(toks):
            groups.append((start, len(toks)))
        elif groups:
            raise AsmError("missing operand after ','", toks[-1].column)
        self.pos = len(toks)
        return groups

    def _expr(self, start: int, stop: int) -> Expr:
        end_column = self.tokens[stop].column if stop < len(self.tokens) else self.end_column
        parser = ExprParser(self.tokens[start:stop], 0, end_column)
        expr = parser.parse()
        if parser.pos < stop - start:
            extra = self.tokens[start + parser.pos]
            raise AsmError(f"unexpected '{extra.text}'", extra.column, len(extra.text))
        return expr

    def _expr_to_end(self) -> Expr:
        start = self.pos
        self.pos = len(self.tokens)
        return self._expr(start, len(self.tokens))

    def _take(self, kind: TokenKind, message: str) -> Token:
        tok = self.tokens[self.pos] if self.pos < len(self.tokens) else None
        if tok is None or tok.kind is not kind:
            raise AsmError(message, tok.column if tok else self.end_column)
        self.pos += 1
        return tok

    def _take_punct(self, text: str, message: str) -> None:
        tok = self._take(TokenKind.PUNCT, message)
        if tok.text != text:
            raise AsmError(message, tok.column)

    def _expect_end(self) -> None:
        if self.pos < len(self.tokens):
            tok = self.tokens[self.pos]
            raise AsmError(f"unexpected '{tok.text}'", tok.column, len(tok.text))

    @staticmethod
    def _check_name(tok: Token) -> None:
        if tok.text.upper() in RESERVED:
            raise AsmError(
                f"'{tok.text}' is reserved and cannot name a symbol", tok.column, len(tok.text)
            )
