"""The assembler's error type; its codes are ``asictl.codes.AssemblerCode`` (docs/assembler.md)."""

from __future__ import annotations

from asictl.codes import AssemblerCode as Code

__all__ = ["AsmError", "Code"]


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
