"""Grammar rules of ``grammar/il.lark`` -> AST nodes of ``asictl.il.ast``.

The builder runs inside the LALR parser (lark's ``transformer=`` option), so no parse
tree is built: on a 10,000-line program that saves a third of the time of
parse-then-transform. Rules then see no ``meta`` positions, which they do not need: every
span starts at a token (the operator of an instruction, the mark of an operand), and
tokens carry their line and column. It is a plain class rather than a lark
``Transformer``: lark then builds the trees of the rules that have no method here (the
ones it inlines) directly, without a ``__default__`` call each.

One method per grammar rule or alias; ``tests/frontend`` checks that none is missing.
"""

from __future__ import annotations

from typing import Any, Protocol

from lark import Token

from asictl.diagnostics import Span
from asictl.il import ast
from asictl.platform.master import IO_CODES

TRUE_WORDS = frozenset({"yes", "on", "true"})

#: One item of a section: a node, or a [RAW] record as a plain string.
SectionItem = (
    ast.Option | ast.SlaveSetup | ast.Declaration | ast.Statement | ast.GatingLine
    | ast.AsmLine | str
)
#: A file reads as a flat list of these: section titles (tokens, and the END_REST token
#: after [END]), each followed by the items of its section.
Piece = Token | SectionItem

_K = ast.OperandKind
_MARKS = {
    "I_MARK": _K.I, "I2_MARK": _K.I2, "Q_MARK": _K.Q, "F_MARK": _K.F,
    "IB_MARK": _K.IB, "I2B_MARK": _K.I2B, "QB_MARK": _K.QB, "FY_MARK": _K.FY,
    "PSEG_MARK": _K.PSEG, "KT_MARK": _K.KT, "KC_MARK": _K.KC, "KB_MARK": _K.KB,
    "KW_MARK": _K.KW,
}
_BIT, _BYTE, _WORD = ast.Width.BIT, ast.Width.BYTE, ast.Width.WORD
_CONSTANT_WIDTHS = {_K.KT: _WORD, _K.KC: _WORD, _K.KB: _BYTE, _K.KW: _WORD}
_STORE_OPS = {"EQ": ast.StoreOp.ASSIGN, "S": ast.StoreOp.SET, "R": ast.StoreOp.RESET}
_ARITH_OPS = {"PLUS": ast.ArithOp.ADD, "MINUS": ast.ArithOp.SUB}
_COMPARE_OPS = {
    "CMP_EQ": ast.CompareOp.EQ, "CMP_NE": ast.CompareOp.NE, "CMP_GT": ast.CompareOp.GT,
    "CMP_GE": ast.CompareOp.GE, "CMP_LT": ast.CompareOp.LT, "CMP_LE": ast.CompareOp.LE,
}


def number(token: Token) -> int:
    """The value of a NUMBER token: ``12``, ``16d``, ``0Ah``, ``Eh``.

    The grammar admits at most 9 significant decimal digits, so int() never meets its
    limit on digit strings (leading zeros are stripped first, they count towards it).
    """
    text: str = token.value
    suffix = text[-1]
    if suffix in "hH":
        return int(text[:-1], 16)
    if suffix in "dD":
        text = text[:-1]
    return int(text.lstrip("0") or "0")


class _Node(Protocol):
    """An AST node: every node the builder makes has its span."""

    @property
    def span(self) -> Span | None: ...


#: The children of a rule that mixes tokens and nodes, in grammar order. Which child is a
#: token and which a node of what type is fixed by the grammar, not by anything mypy sees;
#: the rules annotate what they take out of them.
_Mixed = list[Any]


def _end(item: Token | _Node) -> int:
    """The column just after a token or a node (all constructs lie on one line)."""
    if isinstance(item, Token):
        assert item.end_column is not None  # the lexer places every token
        return item.end_column
    span = item.span
    assert span is not None
    return span.column + span.length


def _word(operand: ast.Operand) -> ast.Operand:
    """A timer or counter as a word: the remaining time, the count (L, T, CU, CD, STP)."""
    if operand.width is not _BIT or (operand.kind is not _K.T and operand.kind is not _K.C):
        return operand
    return ast.Operand(operand.kind, operand.address, -1, _WORD, "", operand.span)


class AstBuilder:
    """Builds AST nodes for one file at a time: set ``file`` before each parse."""

    def __init__(self) -> None:
        self.file = "<string>"

    def _span(self, first: Token | Span, last: Token | _Node | None = None) -> Span:
        """From ``first`` (a token, or the span of a node) to the end of ``last`` (of
        ``first``, a token then, if None)."""
        if last is None:
            assert isinstance(first, Token)
            last = first
        end = _end(last)
        line, column = first.line, first.column
        assert line is not None and column is not None  # the lexer places every token
        return Span(self.file, line, column, end - column)

    # -------------------------------------------------------------- file structure
    # The start rules return the file as a flat list: title tokens, each followed by the
    # nodes of its section; asictl.il.parser groups them into sections.

    def start(self, children: list[Piece]) -> list[Piece]:
        return children

    options_rest = setup_rest = decl_rest = program_rest = start
    gating_rest = assembly_rest = raw_rest = start

    # ------------------------------------------------------- [OPTIONS], [SETUP], [DECL]

    def option(self, c: list[Token]) -> ast.Option:
        name, value = c
        return ast.Option(name.value, value.lower() in TRUE_WORDS, self._span(name, value))

    def slave_setup(self, c: list[Token]) -> ast.SlaveSetup:
        address, io, ident = c[0], c[1], c[2]
        io_code = IO_CODES[io.lower()] if io.type == "IO_CODE" else number(io)
        parameter = number(c[3]) if len(c) == 4 else None
        return ast.SlaveSetup(
            number(address), io_code, number(ident), parameter, self._span(address, c[-1])
        )

    def var_decl(self, c: list[Token]) -> ast.VarDecl:
        return ast.VarDecl(c[0].value, number(c[2]), self._span(c[0], c[2]))

    def timer_decl(self, c: list[Token]) -> ast.TimerDecl:
        return ast.TimerDecl(number(c[1]), self._span(c[0], c[2]))

    def counter_decl(self, c: list[Token]) -> ast.CounterDecl:
        return ast.CounterDecl(number(c[1]), self._span(c[0], c[2]))

    def fb_decl(self, c: list[Token]) -> ast.FBDecl:
        return ast.FBDecl(c[0].value, c[2].value, self._span(c[0], c[2]))

    # ------------------------------------------------------------------- operands

    def image_bit(self, c: list[Token]) -> ast.Operand:
        mark = c[0]
        return ast.Operand(
            _MARKS[mark.type], number(c[-2]), number(c[-1]), _BIT, "", self._span(mark, c[-1])
        )

    def timer(self, c: list[Token]) -> ast.Operand:
        # a status bit; load and transfer make it the word
        return ast.Operand(_K.T, number(c[1]), -1, _BIT, "", self._span(c[0], c[1]))

    def counter(self, c: list[Token]) -> ast.Operand:
        return ast.Operand(_K.C, number(c[1]), -1, _BIT, "", self._span(c[0], c[1]))

    def var_bit(self, c: list[Token]) -> ast.Operand:
        name, offset, bit = c
        return ast.Operand(
            _K.VAR, number(offset), number(bit), _BIT, name.value, self._span(name, bit)
        )

    def image_byte(self, c: list[Token]) -> ast.Operand:
        return ast.Operand(_MARKS[c[0].type], number(c[1]), -1, _BYTE, "", self._span(c[0], c[1]))

    def var_byte(self, c: list[Token]) -> ast.Operand:
        return ast.Operand(_K.VAR, number(c[1]), -1, _BYTE, c[0].value, self._span(c[0], c[1]))

    def flag_word(self, c: list[Token]) -> ast.Operand:
        return ast.Operand(_K.FW, number(c[1]), -1, _WORD, "", self._span(c[0], c[1]))

    def constant(self, c: list[Token]) -> ast.Operand:
        kind = _MARKS[c[0].type]
        return ast.Operand(
            kind, number(c[1]), -1, _CONSTANT_WIDTHS[kind], "", self._span(c[0], c[1])
        )

    def param_const(self, c: list[Token]) -> ast.Operand:
        return ast.Operand(_K.KP, number(c[1]), number(c[2]), _WORD, "", self._span(c[0], c[2]))

    # --------------------------------------------------------------- instructions

    def label(self, c: list[Token]) -> ast.Label:
        return ast.Label(c[0].value, self._span(c[0]))

    def logic(self, c: _Mixed) -> ast.Logic:
        op: Token
        operand: ast.Operand
        op, operand = c
        return ast.Logic(ast.LogicOp[op.type], operand, self._span(op, operand))

    def store(self, c: _Mixed) -> ast.Store:
        op: Token
        operand: ast.Operand
        op, operand = c
        return ast.Store(_STORE_OPS[op.type], operand, self._span(op, operand))

    def not_(self, c: list[Token]) -> ast.Not:
        return ast.Not(self._span(c[0]))

    def load(self, c: _Mixed) -> ast.Load:
        op: Token = c[0]
        operand: ast.Operand = _word(c[1])
        return ast.Load(operand, self._span(op, operand))

    def transfer(self, c: _Mixed) -> ast.Transfer:
        op: Token = c[0]
        operand: ast.Operand = _word(c[1])
        return ast.Transfer(operand, self._span(op, operand))

    def arith(self, c: list[Token]) -> ast.Arith:
        return ast.Arith(_ARITH_OPS[c[0].type], self._span(c[0], c[1]))

    def compare(self, c: list[Token]) -> ast.Compare:
        return ast.Compare(_COMPARE_OPS[c[0].type], self._span(c[0], c[1]))

    def count(self, c: _Mixed) -> ast.Count:
        op: Token = c[0]
        counter: ast.Operand = _word(c[1])
        return ast.Count(ast.CountOp[op.type], counter, self._span(op, counter))

    def segment_end(self, c: list[Token]) -> ast.SegmentEnd:
        return ast.SegmentEnd(self._span(c[0]))

    def block_end(self, c: list[Token]) -> ast.BlockEnd:
        return ast.BlockEnd(ast.EndKind[c[0].type], self._span(c[0]))

    def jump(self, c: list[Token]) -> ast.Jump:
        return ast.Jump(c[0].type == "JC", c[-1].value, self._span(c[0], c[-1]))

    def call_fb(self, c: list[Token]) -> ast.CallFB:
        return ast.CallFB(c[0].type == "JC", c[2].value, self._span(c[0], c[2]))

    def param(self, c: list[Token]) -> ast.Param:
        return ast.Param(self._span(c[0]))

    def asm(self, c: list[Token]) -> ast.Asm:
        return ast.Asm(c[1].value, self._span(c[0], c[1]))

    # ------------------------------------------------------------------- [GATING]

    def gating_line(self, c: _Mixed) -> ast.GatingLine:
        target: ast.Operand = c[0]
        terms: tuple[ast.GatingTerm, ...] = tuple(c[2:])
        assert target.span is not None
        return ast.GatingLine(target, terms, self._span(target.span, terms[-1]))

    def gating_term(self, c: _Mixed) -> ast.GatingTerm:
        operand: ast.Operand = c[-1]
        if len(c) == 1:
            return ast.GatingTerm(None, False, operand, operand.span)
        return ast.GatingTerm(None, True, operand, self._span(c[0], operand))

    def gating_combine(self, c: _Mixed) -> ast.GatingTerm:
        op: Token = c[0]
        operand: ast.Operand = c[-1]
        negated = len(c) == 3
        gate = ast.GatingOp.AND if op.type == "AND" else ast.GatingOp.OR
        return ast.GatingTerm(gate, negated, operand, self._span(op, operand))

    # -------------------------------------------------------------- [ASSEMBLY], [RAW]

    def asm_line(self, c: list[Token]) -> ast.AsmLine:
        return ast.AsmLine(c[0].value, self._span(c[0]))

    def raw_record(self, c: list[Token]) -> str:
        # The plain string, not the token: in the flat list of a file, tokens are titles.
        record: str = c[0].value
        return record
