"""Which operands a debugger shows: the input and output bits of the [SETUP] slaves (from
the image's projected configuration, so an image without its source has them too), the
flags the program's lines use (from its source), its timers and counters (from the
program map), the names of the symbol table."""

from __future__ import annotations

from dataclasses import dataclass

from asictl.il import ast
from asictl.il.loader import Program
from asictl.image.eeprom import ProgramImage
from asictl.observe.iltrace import line_operands
from asictl.observe.symbols import SymbolTable
from asictl.platform.master import IO_CODE_BITS


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
            node = operand.node
            if node.kind in (ast.OperandKind.F, ast.OperandKind.FY):
                flags.add((node.address, node.bit, str(operand)))
        pmap = image.pmap
        return cls(
            tuple(io),
            tuple(text for _, _, text in sorted(flags)),
            tuple([f"T {n}" for n in sorted(pmap.timers)]
                  + [f"C {n}" for n in sorted(pmap.counters)]),
            tuple(name for name, _ in symbols.entries.values()),
        )

    def as_json(self) -> dict[str, list[str]]:
        return {"io": list(self.io), "flags": list(self.flags),
                "timers_counters": list(self.timers_counters), "symbols": list(self.symbols)}
