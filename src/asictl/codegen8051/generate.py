"""Walk a checked program and write its 8051 instructions into an output stream.

The layout of the generated source: symbol definitions (the manual's 3.6.1 names, so
hand-written assembly can use them), the main program at ``CODE_BASE`` entered each
cycle, then each called user block as a subroutine, then the runtime helpers used.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import assert_never

from asictl.codegen8051.emitter import (
    ENTRY_SYMBOL,
    PSEG_SYMBOL,
    Emitter,
    block_symbol,
    counter_symbol,
    label_symbol,
    timer_symbol,
)
from asictl.codegen8051.stream import C, Comment, End, Org, OutputStream, hex_number
from asictl.il import ast
from asictl.il.loader import Program
from asictl.runtime import layout
from asictl.runtime.firmware import FIRMWARE_BLOCKS
from asictl.runtime.program_map import ProgramMap


def generate(program: Program, pmap: ProgramMap, table: Mapping[str, int]) -> OutputStream:
    """``table`` is the program's ``symbols``, taken rather than built here: the caller
    gives the assembler the same one."""
    out = Emitter(pmap=pmap)
    for name, value in table.items():
        out.out.add(Comment(f"{name} = {hex_number(value)}"))
    out.span = None
    out.out.add(Org(layout.CODE_BASE))
    out.label(ENTRY_SYMBOL)
    out.emit("CLR", C)  # the register starts every cycle at 0
    _body(out, program.main, None, set(program.blocks))
    for name, module in program.blocks.items():
        out.span = None
        out.label(block_symbol(name))
        _body(out, module, name, set(program.blocks))
    out.helpers()
    out.out.add(End())
    return out.out


def symbols(
    program: Program, pmap: ProgramMap, entry_points: Mapping[str, int]
) -> dict[str, int]:
    """The names of 3.6.1 the program's assembly (and hand-written ASM) may use.

    They reach the assembler as predefined symbols, so a variable may even be named like
    an SFR (its name then means the variable, as the manual's conventions say).
    """
    table = {f"_{b.name}_": entry_points[name] for name, b in FIRMWARE_BLOCKS.items()}
    table[PSEG_SYMBOL] = pmap.pseg
    table.update({timer_symbol(n): address for n, address in pmap.timers.items()})
    table.update({counter_symbol(n): address for n, address in pmap.counters.items()})
    table.update({v.name: v.address for v in pmap.variables.values()})
    return table


def _body(out: Emitter, module: ast.Module, scope: str | None, user_blocks: set[str]) -> None:
    for section in module.sections:
        match section:
            case ast.ProgramSection(statements=statements):
                _statements(out, statements, scope, user_blocks)
            case ast.GatingSection(lines=gating_lines):
                for gating_line in gating_lines:
                    out.span = gating_line.span
                    out.gating(gating_line)
            case ast.AssemblySection(lines=asm_lines):
                for asm_line in asm_lines:
                    out.span = asm_line.span
                    out.raw(asm_line.text)
            case ast.OptionsSection() | ast.SetupSection() | ast.DeclSection() | ast.RawSection():
                pass  # they configure; they hold no code
            case _:
                assert_never(section)
    out.span = None
    out.emit("RET")  # the end of the last section is an implicit BE


def _statements(
    out: Emitter, statements: tuple[ast.Statement, ...], scope: str | None, user_blocks: set[str]
) -> None:
    first = True  # each [PROGRAM] section starts a segment
    for statement in statements:
        out.span = statement.span
        match statement:
            case ast.Logic(op=op, operand=operand):
                out.logic(op, operand, first)
                first = False
            case ast.Store(op=op, operand=operand):
                out.store(op, operand)
            case ast.Not():
                out.emit("CPL", C)
            case ast.Load(operand=operand):
                out.load(operand)
            case ast.Transfer(operand=operand):
                out.transfer(operand)
            case ast.Arith(op=op):
                out.arith(op)
            case ast.Compare(op=op):
                out.compare(op)
                first = False
            case ast.Count(op=op, counter=counter):
                out.count(op, counter.address)
            case ast.SegmentEnd():
                first = True
            case ast.BlockEnd(kind=kind):
                out.block_end(kind)
            case ast.Jump(conditional=conditional, label=label):
                out.jump(conditional, label_symbol(scope, label))
            case ast.CallFB(conditional=conditional, name=name):
                out.call(conditional, name, user_blocks)
            case ast.Param():
                out.param()
            case ast.Asm(text=text):
                out.raw(text)
            case ast.Label(name=name):
                out.label(label_symbol(scope, name))
            case _:
                assert_never(statement)
