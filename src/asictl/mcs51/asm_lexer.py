"""Splitting one line of 8051 assembly into tokens, and reading its number forms.

Assembly is line-oriented, so the lexer works a line at a time; columns are 1-based
character positions, matching how diagnostics count them (a tab is one column).
Numbers accept both the Intel ASM51 suffix forms (0FFh, 1010b, 17o, 17q, 99d) and the
C-like prefixes as31 sources use (0x1F, 0b101).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from enum import Enum

from asictl.mcs51.asm_errors import AsmError


class TokenKind(Enum):
    IDENT = "identifier"
    NUMBER = "number"
    STRING = "string"
    PUNCT = "punctuation"


@dataclass(frozen=True, slots=True)
class Token:
    kind: TokenKind
    text: str
    column: int
    #: Decoded contents of a STRING token (quotes removed, escapes applied).
    value: str = ""


_TOKEN = re.compile(
    r"""
    (?P<space>[ \t\f\v]+)
  | (?P<comment>;.*)
  | (?P<ident>[A-Za-z_?][A-Za-z0-9_?]*)
  | (?P<number>[0-9][0-9A-Za-z]*)
  | (?P<string>'(?:[^'\\]|\\.)*'|"(?:[^"\\]|\\.)*")
  | (?P<punct><<|>>|[-+*/%&|^~()\#@.,:!$])
  | (?P<bad>.)
    """,
    re.VERBOSE,
)

_ESCAPES = {"b": "\b", "n": "\n", "r": "\r", "t": "\t", "0": "\0", "'": "'", '"': '"', "\\": "\\"}
_ESCAPE = re.compile(r"\\(.)")


def _unescape(body: str, column: int) -> str:
    def replace(match: re.Match[str]) -> str:
        char = match.group(1)
        if char not in _ESCAPES:
            raise AsmError(f"unknown escape '\\{char}' in string", column + match.start(), 2)
        return _ESCAPES[char]

    return _ESCAPE.sub(replace, body)


def tokenize(line: str) -> list[Token]:
    """The tokens of one source line, without blanks and the trailing ``;`` comment."""
    tokens: list[Token] = []
    for match in _TOKEN.finditer(line):
        kind = match.lastgroup
        text = match.group()
        column = match.start() + 1
        if kind == "ident":
            tokens.append(Token(TokenKind.IDENT, text, column))
        elif kind == "number":
            tokens.append(Token(TokenKind.NUMBER, text, column))
        elif kind == "punct":
            tokens.append(Token(TokenKind.PUNCT, text, column))
        elif kind == "string":
            value = _unescape(text[1:-1], column + 1)
            tokens.append(Token(TokenKind.STRING, text, column, value))
        elif kind == "bad":
            if text in "'\"":
                raise AsmError("string has no closing quote", column, len(line) - column + 1)
            raise AsmError(f"unexpected character {text!r}", column)
        elif kind == "comment":
            break
    return tokens


_BASES = {"b": 2, "o": 8, "q": 8, "d": 10}
_DIGITS = {2: "01", 8: "01234567", 10: "0123456789", 16: "0123456789abcdef"}


def parse_number(text: str) -> int:
    """The value of a number token; ``ValueError`` (with a message) if it is malformed.

    A 0x prefix wins over any suffix (0x1B is hex, as in as31), then an h suffix (0B1h
    is hex), then a 0b prefix (0b101); otherwise a b/o/q/d suffix picks the base.
    A leading zero does not mean octal: as31 reads 010 as ten, as ASM51 does.
    """
    lower = text.lower()
    if lower.startswith("0x"):
        base, digits = 16, lower[2:].removesuffix("h")
    elif lower.endswith("h"):
        base, digits = 16, lower[:-1]
    elif lower.startswith("0b") and len(lower) > 2 and set(lower[2:]) <= {"0", "1"}:
        base, digits = 2, lower[2:]
    elif lower[-1] in _BASES:
        base, digits = _BASES[lower[-1]], lower[:-1]
    else:
        base, digits = 10, lower
    if not digits or any(c not in _DIGITS[base] for c in digits):
        raise ValueError(f"malformed number '{text}'")
    significant = digits.lstrip("0")
    # 32 bits are at most 32 binary digits; checked before int() meets a huge string
    if len(significant) > 32 or int(significant or "0", base) >= 1 << 32:
        shown = text if len(text) <= 20 else f"{text[:16]}...{text[-2:]}"
        raise ValueError(f"number '{shown}' does not fit in 32 bits")
    return int(digits, base)
