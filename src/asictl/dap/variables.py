"""The scopes an editor shows at a stop, and which operands go in each.

The registers always; the input and output bits of the [SETUP] slaves (from the image's
projected configuration, so an image without its source has them too); the flags the
program's lines use (from its source); its timers and counters (from the program map);
the names of the symbol table. Values come from the target (``show``), formatted as the
debugger's ``print`` shows them, so the editor and the command line agree.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from asictl.dap.targets import Scope, Variable
from asictl.il import ast
from asictl.il.loader import Program
from asictl.image.eeprom import ProgramImage
from asictl.observe.iltrace import line_operands
from asictl.observe.symbols import SymbolTable
from asictl.platform.master import IO_CODE_BITS

#: The IL machine's registers, as ``print`` names them.
REGISTERS = ("RLO", "ACCU1", "ACCU2")
#: The scope of the constant register (not an operand, so not ``print``-able).
CONSTANT = "constant register"


@dataclass(frozen=True)
class Inventory:
    """The operands of each scope, as operand texts (``I 1.0``, ``FY 10``, ``T 1``)."""

    io: tuple[str, ...] = ()
    flags: tuple[str, ...] = ()
    timers_counters: tuple[str, ...] = ()
    symbols: tuple[str, ...] = ()

    @classmethod
    def of(cls, image: ProgramImage, program: Program | None,
           symbols: SymbolTable) -> Inventory:
        io = []
        for slave in image.configuration.slaves():
            letters = IO_CODE_BITS[slave.io_code]
            io += [f"I {slave.address}.{b}" for b in range(4) if letters[b] in "ib"]
            io += [f"Q {slave.address}.{b}" for b in range(4) if letters[b] in "ob"]
        flags: set[tuple[int, int, str]] = set()
        for operand in line_operands(program).values():
            match operand.node:
                case ast.ImageBit(area=ast.BitArea.F, address=a, bit=b):
                    flags.add((a, b, str(operand)))
                case ast.ImageByte(area=ast.ByteArea.FY, number=n):
                    flags.add((n, -1, str(operand)))
        pmap = image.pmap
        return cls(
            tuple(io),
            tuple(text for _, _, text in sorted(flags)),
            tuple([f"T {n}" for n in sorted(pmap.timers)]
                  + [f"C {n}" for n in sorted(pmap.counters)]),
            tuple(name for name, _ in symbols.entries.values()),
        )


def _settable(text: str) -> bool:
    return text.split()[0].upper() in ("I", "IB", "F", "FY")


def scopes(
    inventory: Inventory, show: Callable[[list[str]], list[str]], constant: int
) -> list[Scope]:
    """The scopes with their values; ``show`` formats a list of operands at once (a live
    board answers them in one request)."""
    groups = [("Registers", REGISTERS), ("Inputs and outputs", inventory.io),
              ("Flags", inventory.flags), ("Timers and counters", inventory.timers_counters),
              ("Symbols", inventory.symbols)]
    names = [name for _, group in groups for name in group]
    values = dict(zip(names, show(names), strict=True))
    found = []
    for title, group in groups:
        if not group:
            continue
        variables = [Variable(n, values[n], _kind(n), _settable(n)) for n in group]
        if title == "Registers":
            variables.append(Variable(CONSTANT, f"{constant} ({constant:04X}h)", "word"))
        if title == "Symbols":
            variables = [Variable(v.name, v.value, "symbol", True) for v in variables]
        found.append(Scope(title, variables))
    return found


def _kind(text: str) -> str:
    mark = text.split()[0].upper()
    if mark in ("RLO", "I", "Q", "F", "I2"):
        return "bit"
    if mark in ("T", "C"):
        return "timer" if mark == "T" else "counter"
    return "word" if mark.startswith("ACCU") else "byte"
