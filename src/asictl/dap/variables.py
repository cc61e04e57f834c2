"""The scopes an editor shows at a stop: the registers, then the operands of
``debug.inventory`` by kind. Values come from the target (``show``), formatted as the
debugger's ``print`` shows them, so the editor and the command line agree.
"""

from __future__ import annotations

from collections.abc import Callable

from asictl.dap.targets import Scope, Variable
from asictl.debug.inventory import Inventory

#: The IL machine's registers, as ``print`` names them.
REGISTERS = ("RLO", "ACCU1", "ACCU2")
#: The scope of the constant register (not an operand, so not ``print``-able).
CONSTANT = "constant register"


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
