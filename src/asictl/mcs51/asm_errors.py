"""The assembler's error type and diagnostic codes, one code per kind of problem.

Codes let editors, CI filters and tests tell problems apart without matching message
text; ``docs/assembler.md`` lists them.
"""

from __future__ import annotations

from enum import StrEnum


class Code(StrEnum):
    SYNTAX = "E501"
    UNKNOWN_MNEMONIC = "E502"
    BAD_OPERAND = "E503"
    OUT_OF_RANGE = "E504"
    JUMP_TOO_FAR = "E505"
    OTHER_PAGE = "E506"
    UNDEFINED = "E507"
    DUPLICATE = "E508"
    NOT_BIT_ADDRESSABLE = "E509"
    OVERLAP = "E510"
    INCLUDE = "E511"
    EXPRESSION = "E512"
    AMBIGUOUS_PRECEDENCE = "E513"
    NOT_YET_KNOWN = "E514"
    TYPE_MISMATCH = "W501"
    AFTER_END = "W502"


class AsmError(Exception):
    """A problem on one line, located by column and width; becomes a ``Diagnostic``."""

    def __init__(
        self, message: str, column: int, length: int = 1, code: Code = Code.SYNTAX
    ) -> None:
        super().__init__(message)
        self.message = message
        self.column = column
        self.length = max(1, length)
        self.code = code
