"""The board's symbol table: names for operands, read from the program on the master.

``asictl download`` stores the program's ``NAME.symbols.toml`` with its source in the
image (``build.build_file``), so every online command can take and show names without
the file at hand: ``write Motor=1``, ``force Motor=1``, ``watch Motor``, ``bus inputs
Start=1``, ``status`` (names beside operands) and the monitor. Reading the table means
reading the image (Upload, 53), so ``Names`` reads it only when a name is met that is no
operand, or when asked for the table.
"""

from __future__ import annotations

from asictl.errors import ExitCode, UserError
from asictl.host.master import Master
from asictl.host.status import read_program
from asictl.observe.operands import (
    Assignment,
    Operand,
    parse_assignment,
    parse_operand,
)
from asictl.observe.symbols import SymbolTable
from asictl.readers.suggest import closest


def board_symbols(master: Master) -> SymbolTable:
    """The symbol table of the program in the master's EEPROM (empty without one)."""
    return read_program(master.transport).symbols


class Names:
    """Operands and ``OPERAND=VALUE`` as a command reads them on one master: operands
    as written, else names from the board's symbol table (read once, when needed).
    Errors are ``UserError`` with exit 2 (bad usage)."""

    def __init__(self, master: Master, table: SymbolTable | None = None) -> None:
        """``table``: the board's, where the caller has read it already."""
        self.master = master
        self._table = table

    @property
    def table(self) -> SymbolTable:
        if self._table is None:
            self._table = board_symbols(self.master)
        return self._table

    def assignment(self, text: str, *, example: str) -> Assignment:
        try:
            return parse_assignment(text, example=example)
        except ValueError as exc:
            first = exc
        name = text.rpartition("=")[0]
        if "=" in text and self.table.resolve(name) != name.strip():
            try:
                return parse_assignment(text, symbols=self.table, example=example)
            except ValueError as exc:
                first = exc
        raise UserError(self._unknown(str(first), name if "=" in text else text),
                        ExitCode.USAGE)

    def operand(self, text: str) -> Operand:
        try:
            return parse_operand(text)
        except ValueError as exc:
            first = exc
        if self.table.resolve(text) != text:
            try:
                return parse_operand(text, symbols=self.table)
            except ValueError as exc:
                first = exc
        raise UserError(self._unknown(str(first), text), ExitCode.USAGE)

    def _unknown(self, message: str, word: str) -> str:
        """The message, with the name of the board's table most like ``word`` where the
        message has no hint of its own (``Wtaer`` -> ``'Water' (I 1.2)``)."""
        if self._table is None or "did you mean" in message:
            return message
        if not self._table:
            return message + " (and the program on the master has no symbol table)"
        operands = dict(self._table.entries.values())
        found = closest(word.strip(), operands)
        return message + (f"; did you mean '{found}' ({operands[found]})?" if found else "")
