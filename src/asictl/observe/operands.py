"""Operands and their values as people name them: in scenarios (``"I 4.0"``, ``"QB 16"``,
``"Reading 3"``), in the debugger, in ``--set``, ``asictl write``, ``asictl bus inputs``
and the monitor's prompt. An operand is read exactly as the IL reader reads it, so every
tool speaks the program's own language, and it is the IL's own ``ast.Operand``.

Three forms are the tools' own, for what people check and set when they debug and
commission: ``CV n``, a counter's value (0..4095), ``TV n``, a timer's remaining time in
milliseconds (counter and timer as words, as ``L C n`` and ``L T n`` load them), and
``I n``/``Q n``, the four input or output data bits of slave n at once. A symbol table
(``asictl.observe.symbols``) may name any of them.

``parse_assignment`` reads ``OPERAND=VALUE`` (``"I 1.0=1"``, ``"FY 12=0x55"``,
``"Motor=1"``) into an ``Assignment``; ``parse_operand`` reads an operand alone,
``parse_value`` a value for one, ``check_value`` a value a file already holds as a number
(a scenario's TOML). Every error is a ``ValueError`` whose message names the part that is
wrong and what it may be; each tool decides which operands it lets people set.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, assert_never

from asictl.diagnostics import DiagnosticError
from asictl.il import ast
from asictl.il.ast import key
from asictl.il.language import TC_MAX_VALUE
from asictl.observe.symbols import SymbolTable, read_symbols
from asictl.platform.master import TICK_MS
from asictl.source import from_bytes

if TYPE_CHECKING:
    from asictl.image.eeprom import ProgramImage

_VALUE = re.compile(r"^\s*(CV|TV)\s*(\d{1,6})\s*$", re.IGNORECASE)
#: ``I 4``, ``I2 4``, ``Q 17``: a slave's four data bits (``I2`` takes a blank before the
#: number: ``I24`` is slave 24, as in IL).
_NIBBLE = re.compile(r"^\s*(?:(I2)\s+|(I|Q)\s*)(\d{1,6})\s*$", re.IGNORECASE)
#: The largest remaining time a timer can hold, in milliseconds.
TIMER_MAX_MS = TC_MAX_VALUE * TICK_MS
K = ast.OperandKind
#: What a simulation may set (``Operand.settable``), as messages say it.
SETTABLE = "only inputs (I, IB) and flags (F, FY)"
_NIBBLE_KINDS = {"I": K.I, "I2": K.I2, "Q": K.Q}
#: The plain forms of the IL's image bits, bytes, timers and counters, with decimal
#: numbers: ``F 10.0``, ``I2 4.3``, ``Q17.3``, ``QB 16``, ``PSeg 0``, ``T 1``. They are
#: read without the IL reader (``plain_operand``), whose parser and grammar would take
#: most of the time of a one-shot command such as ``asictl force "F 10.0=1"``; every
#: other form goes to the IL reader. I2 takes a blank before its number, as in IL.
_PLAIN_BIT = re.compile(r"^\s*(?:(I2)\s+|(I|Q|F)\s*)(\d{1,4})\.(\d{1,4})\s*$", re.IGNORECASE)
_PLAIN_WHOLE = re.compile(r"^\s*(I2B|IB|QB|FY|PSEG|T|C)\s*(\d{1,4})\s*$", re.IGNORECASE)
_PLAIN_KINDS = {kind.value.upper(): kind for kind in (
    K.I, K.I2, K.Q, K.F, K.IB, K.I2B, K.QB, K.FY, K.PSEG, K.T, K.C
)}


@dataclass(frozen=True)
class Operand:
    """An operand as the tools name it: an IL operand, a bit or a byte, or one of their
    own: ``CV n`` and ``TV n`` (counter n and timer n as words: the count, and the
    remaining time, here in milliseconds) and ``I n``/``Q n`` (a slave's data bits)."""

    node: ast.Operand

    @classmethod
    def value_of(cls, kind: ast.OperandKind, number: int) -> Operand:
        """``CV n`` (kind C) or ``TV n`` (kind T)."""
        return cls(ast.Operand(kind, number, -1, ast.Width.WORD))

    @property
    def is_bit(self) -> bool:
        return self.node.width is ast.Width.BIT

    @property
    def width(self) -> int:
        """Bits a trace needs for it: 1, 4 (a slave's data), 8, 12 (a count) or 16
        (milliseconds)."""
        node = self.node
        if node.width is ast.Width.WORD:
            return 12 if node.kind is K.C else 16
        return int(node.width)

    @property
    def maximum(self) -> int:
        node = self.node
        if node.width is ast.Width.WORD:
            return TC_MAX_VALUE if node.kind is K.C else TIMER_MAX_MS
        return (1 << node.width) - 1

    @property
    def settable(self) -> bool:
        """What a simulation sets (``SETTABLE``): inputs, as slaves deliver them, and flags,
        as a host writes them."""
        return self.node.kind in (K.I, K.F, K.IB, K.FY)

    @property
    def what(self) -> str:
        """What its value is, for messages: a bit, a byte, a count ..."""
        node = self.node
        if node.width is ast.Width.WORD:
            return "a count" if node.kind is K.C else "milliseconds"
        return {ast.Width.BIT: "a bit", ast.Width.NIBBLE: "four data bits",
                ast.Width.BYTE: "a byte"}[node.width]

    def __str__(self) -> str:
        node = self.node
        if node.width is ast.Width.WORD and node.kind in (K.T, K.C):
            return f"{node.kind.value}V {node.address}"
        return str(node)


def plain_operand(text: str) -> ast.Operand | None:
    """The operand ``text`` names if it is written in a plain form (``_PLAIN_BIT``,
    ``_PLAIN_WHOLE``): the one ``il_operand`` reads from it (tests/observe/
    test_operands.py holds the two to it); None for any other form."""
    bit = _PLAIN_BIT.match(text)
    if bit:
        mark = (bit[1] or bit[2]).upper()
        return ast.Operand(_PLAIN_KINDS[mark], int(bit[3]), int(bit[4]), ast.Width.BIT)
    whole = _PLAIN_WHOLE.match(text)
    if whole:
        kind = _PLAIN_KINDS[whole[1].upper()]
        width = ast.Width.BIT if kind in (K.T, K.C) else ast.Width.BYTE
        return ast.Operand(kind, int(whole[2]), -1, width)
    return None


def il_operand(text: str) -> ast.Operand | None:
    """The bit or byte operand the IL reader reads from ``text`` (as ``A text`` or, for a
    byte, ``L text`` reads it); None if it reads none."""
    statement = _statement(f"A {text}")
    if isinstance(statement, ast.Logic):
        return statement.operand
    statement = _statement(f"L {text}")
    loaded = statement.operand if isinstance(statement, ast.Load) else None
    return loaded if loaded is not None and loaded.width is ast.Width.BYTE else None


@functools.lru_cache(maxsize=4096)
def _statement(text: str) -> ast.Statement | None:
    """The one statement ``text`` is (scenarios name the same operands again and again)."""
    from asictl.il.parser import parse_text  # lark: only where an operand is read as IL

    module, diagnostics = parse_text(f"[PROGRAM]\n{text}\n", "<operand>")
    if diagnostics or not module.sections:
        return None
    section = module.sections[0]
    if not isinstance(section, ast.ProgramSection) or len(section.statements) != 1:
        return None
    return section.statements[0]


def parse_operand(
    text: str, variables: Mapping[str, int] | None = None, symbols: SymbolTable | None = None
) -> Operand:
    """The operand ``text`` names; ``ValueError`` with a message for the user if it names
    none, or one out of range.

    ``variables`` are the program's variables (key name -> size in bytes); ``symbols``
    the names of its symbol table."""
    if symbols:
        text = symbols.resolve(text)
    if not text.strip() or "\n" in text or ";" in text:
        raise ValueError(f"'{text}' is not an operand")
    value = _VALUE.match(text)
    if value:
        number = int(value[2])
        if number > 1023:
            raise ValueError(f"'{text}': number 0..1023")
        return Operand.value_of(K.C if value[1].upper() == "CV" else K.T, number)
    nibble = _NIBBLE.match(text)
    node: ast.Operand | None = None
    if nibble:
        mark = (nibble[1] or nibble[2]).upper()
        node = ast.Operand(_NIBBLE_KINDS[mark], int(nibble[3]), -1, ast.Width.NIBBLE)
    if node is None:
        node = plain_operand(text) or il_operand(text)
    if node is None:
        raise ValueError(
            f"'{text}' is not an operand (bits: I, I2, Q, F, T, C, variable bits; a slave's "
            "data bits: I n, Q n; bytes: IB, I2B, QB, FY, PSeg, variable bytes; values: "
            "CV n, TV n" + ("; or a symbol" if symbols else "") + ")"
        )
    _check_range(node, text, variables or {})
    return Operand(node)


def _check_range(node: ast.Operand, text: str, variables: Mapping[str, int]) -> None:
    def need(ok: bool, what: str) -> None:
        if not ok:
            raise ValueError(f"'{text}': {what}")

    a, b = node.address, node.bit
    match node.kind:
        case K.F:
            need(a <= 127 and b <= 7, "flag byte 0..127, bit 0..7")
        case K.I | K.I2 | K.Q:
            if node.width is ast.Width.NIBBLE:
                need(a <= 31, "slave 0..31")
            else:
                need(a <= 31 and b <= 3, "slave 0..31, data bit 0..3")
        case K.T | K.C:
            need(a <= 1023, "number 0..1023")
        case K.FY:
            need(a <= 127, "flag byte 0..127")
        case K.PSEG:
            need(a <= 15, "PSeg byte 0..15")
        case K.IB | K.I2B | K.QB:
            need(a <= 30 and a % 2 == 0, "an even slave address 0..30")
        case K.VAR:
            size = variables.get(key(node.name))
            if size is None:
                raise ValueError(
                    f"'{text}': '{node.name}' is not a variable declared by the program")
            need(a < size, f"'{node.name}' has {size} bytes")
        case K.FW | K.KT | K.KC | K.KB | K.KW | K.KP:
            raise AssertionError(f"{node} is read neither as a bit nor as a byte")
        case _:
            assert_never(node.kind)


# -------------------------------------------------------------------- OPERAND=VALUE


@dataclass(frozen=True)
class Assignment:
    """``OPERAND=VALUE``: an operand and a value within its range."""

    operand: Operand
    value: int
    #: the operand as the text names it (a symbol, or the operand as typed), for messages
    written: str


def read_number(text: str) -> int:
    """A whole number as people and the IL write it: ``12``, ``0x0C``, ``0b1100``, and
    the IL's ``0Ch`` and ``12d``; ``_`` may group digits (``0b1010_0101``). ``ValueError``
    for anything else, negative numbers included."""
    digits = text.strip().lower().replace("_", "")
    base = 10
    if digits.startswith("0x"):
        digits, base = digits[2:], 16
    elif digits.endswith("h"):  # before 0b: 0Bh is eleven
        digits, base = digits[:-1], 16
    elif digits.startswith("0b"):
        digits, base = digits[2:], 2
    elif digits.endswith("d"):
        digits = digits[:-1]
    allowed = "0123456789abcdef"[:base]
    if not digits or any(c not in allowed for c in digits):
        raise ValueError(f"'{text.strip()}' is not a number (such as 11, 0xB, 0Bh or 0b1011)")
    return int(digits, base)


def check_value(value: int, operand: Operand, written: str = "") -> int:
    """``value`` if ``operand`` can hold it; ``written`` names the operand in the message
    (default: as it prints)."""
    if not 0 <= value <= operand.maximum:
        raise ValueError(f"'{written or operand}': value {value} out of range "
                         f"0..{operand.maximum} ({operand.what})")
    return value


def parse_value(text: str, operand: Operand, written: str = "") -> int:
    """A value for ``operand`` as ``read_number`` reads it, within the operand's range."""
    try:
        value = read_number(text)
    except ValueError as exc:
        raise ValueError(f"'{written or operand}': {exc}") from None
    return check_value(value, operand, written)


def parse_assignment(
    text: str, variables: Mapping[str, int] | None = None, symbols: SymbolTable | None = None,
    *, example: str = "I 1.0=1",
) -> Assignment:
    """``OPERAND=VALUE``: ``"I 1.0=1"``, ``"FY 12=0x55"``, ``"Q 17=0b1000"``, ``"Motor=1"``
    (a symbol), ``"CV 0=3"``. The operand as ``parse_operand`` reads it (``variables`` and
    ``symbols`` as there), the value as ``parse_value``; ``ValueError`` names what is
    wrong, and ``example`` shows a form the tool takes when there is no ``=``.
    """
    name, equals, value = text.rpartition("=")
    written = name.strip()
    if not equals or not written or not value.strip():
        given = f"'{text.strip()}': " if text.strip() else ""
        raise ValueError(f"{given}expected OPERAND=VALUE, such as '{example}'")
    operand = parse_operand(written, variables, symbols)
    return Assignment(operand, parse_value(value, operand, written), written)


# -------------------------------------------------------------------- symbol tables


def operand_text(text: str) -> str:
    """An operand as it prints (``"I1.0"`` -> ``"I 1.0"``): the check a symbol table is
    read with, so that a name is found by the operand however the table wrote it."""
    return str(parse_operand(text))


def image_symbols(image: ProgramImage | None) -> SymbolTable:
    """The symbol table an image carries with its source (``asictl download`` stores the
    one beside the program); an empty one without, or if it does not read (its errors
    are for whoever wrote it, at download; a board only shows names)."""
    table = image.symbols() if image is not None else None
    if table is None:
        return SymbolTable()
    try:
        return read_symbols(from_bytes(table[0], table[1]), operand_text)
    except DiagnosticError:
        return SymbolTable()
