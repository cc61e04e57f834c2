"""Hover texts (Markdown): what an instruction does, where an operand is, its name in the
program's symbol table, what declares it, the [SETUP] line of its slave, the times a
timer is started with."""

from __future__ import annotations

from typing import assert_never

from asictl.diagnostics import DiagnosticError
from asictl.errors import UserError
from asictl.il import ast
from asictl.il.ast import key
from asictl.il.references import Occurrence, Role, Symbol, SymbolKind
from asictl.lsp.documents import Analysis
from asictl.lsp.navigation import covers, node_at, operator_span
from asictl.lsp.texts import (
    CONSTANT_LOADS,
    INSTRUCTIONS,
    OPERANDS,
    OPTIONS,
    SECTIONS,
    io_code_text,
)
from asictl.observe.operands import operand_text
from asictl.observe.symbols import symbols_for
from asictl.readers.units import TICK_MS, timer_ticks
from asictl.runtime.firmware import FIRMWARE_BLOCKS
from asictl.runtime.layout import FLAGS_BASE
from asictl.source import symbols_path


def hover(analysis: Analysis, file: str, line: int, column: int) -> str | None:
    module = analysis.module(file)
    if module is None:
        return None
    _, node = node_at(module, line, column)
    if node is None:
        return None
    if isinstance(node, ast.Section):
        entry = SECTIONS[node.kind.value]
        return f"**{entry.syntax}**: {entry.meaning}"
    if isinstance(node, ast.Statement) and covers(operator_span(node), line, column):
        return _instruction(node)
    found = analysis.index.at(file, line, column)
    if found:
        return _symbol(analysis, found[0], found)
    if isinstance(node, ast.Option):
        option = OPTIONS.get(key(node.name))
        if option:
            return f"**{node.name}** (default {option.syntax}): {option.meaning}"
    if isinstance(node, ast.Load) and node.operand.kind in _CONSTANTS:
        return _constant(node.operand)
    return None


#: The constants that name nothing (KP names its slave, which has a hover of its own).
_CONSTANTS = (ast.OperandKind.KT, ast.OperandKind.KC, ast.OperandKind.KB, ast.OperandKind.KW)


def _instruction(statement: ast.Statement) -> str:
    text = statement.to_source()
    operator = text.upper().split(" ")[0]
    entry = INSTRUCTIONS.get(operator)
    if isinstance(statement, ast.Load):
        entry = CONSTANT_LOADS.get(statement.operand.kind.value, entry)
    if entry is None:
        return f"`{text}`"
    extra = ""
    if isinstance(statement, ast.Logic):
        extra = ("\n\nAt the start of a program, block, section or segment (first check) "
                 "it loads the operand instead.")
    return f"**{operator}** `{entry.syntax}`: {entry.meaning}{extra}"


def _mark(operand: ast.Operand) -> str:
    entry = OPERANDS.get(operand.kind.value.upper())
    return f"`{entry.syntax}`: {entry.meaning}" if entry else ""


def _constant(constant: ast.Operand) -> str:
    head = f"**{constant}**: {_mark(constant)}"
    value = constant.address
    if constant.kind is ast.OperandKind.KT:
        return f"{head}\n\n{value} ms = {timer_ticks(value)} ticks of {TICK_MS} ms"
    return f"{head}\n\n= {value} = {value:X}h"


def _symbol(analysis: Analysis, occurrence: Occurrence, found: list[Occurrence]) -> str:
    symbol = occurrence.symbol
    node = occurrence.node
    parts: list[str] = []
    operand = _operand_of(node, occurrence)
    if operand is not None:
        parts.append(f"**{operand}**: {_mark(operand)}")
        parts.append(_where(operand))
        parts.append(_symbol_name(occurrence.span.file, operand))
    match symbol.kind:
        case SymbolKind.LABEL:
            parts.append(_label(analysis, symbol))
        case SymbolKind.BLOCK:
            parts.append(_block(analysis, symbol, node))
        case SymbolKind.VARIABLE:
            parts.append(_declaration(analysis, symbol, "variable"))
        case SymbolKind.TIMER | SymbolKind.COUNTER:
            parts.append(_timer_or_counter(analysis, symbol))
    for other in found:
        if other.symbol.kind is SymbolKind.SLAVE:
            parts.append(_slave(analysis, other.symbol))
    return "\n\n".join(p for p in parts if p)


def _symbol_name(file: str, operand: ast.Operand) -> str:
    """The operand's name in the symbol table beside the file (``NAME.symbols.toml``, the
    table a download stores on the board), if it has one; a table with errors names
    nothing (``asictl sim`` and ``download`` report them)."""
    try:
        table = symbols_for(file, operand_text)
    except (DiagnosticError, UserError):
        return ""
    name = table.label(str(operand)) if table else None
    if not name or name == str(operand):
        return ""
    return f"symbol `{name}` ({symbols_path(file).name})"


def _operand_of(node: ast.BodyNode | None, occurrence: Occurrence) -> ast.Operand | None:
    """The operand at the occurrence's place, when it is one (not a label, block, decl)."""
    if occurrence.role in (Role.DEFINE, Role.DECLARE) or occurrence.symbol.kind in (
            SymbolKind.LABEL, SymbolKind.BLOCK):
        return None
    if not isinstance(node, ast.Statement | ast.GatingLine):
        return None
    return next((o for o, _ in ast.operands(node) if o.span == occurrence.span), None)


def _where(operand: ast.Operand) -> str:
    """Where an operand lives."""
    K = ast.OperandKind
    n, bit = operand.address, operand.bit
    match operand.kind:
        case K.F:
            return (f"flag byte {n}, bit {bit}: communication memory "
                    f"{FLAGS_BASE + n:03X}h (the host can read and write it)")
        case K.I | K.I2 | K.Q:
            image = {K.I: "input", K.I2: "previous cycle's input", K.Q: "output"}[operand.kind]
            return f"slave {n}, data bit D{bit} ({image})"
        case K.FY:
            return f"communication memory {FLAGS_BASE + n:03X}h"
        case K.FW:
            return (f"FY {n} (high byte, {FLAGS_BASE + n:03X}h) and FY {n + 1} "
                    f"(low byte, {FLAGS_BASE + n + 1:03X}h)")
        case K.PSEG:
            return "the firmware blocks' arguments and results"
        case K.IB | K.I2B | K.QB:
            return f"slaves {n} (D0-D3 = bits 0-3) and {n + 1} (bits 4-7)"
        case K.VAR:
            if operand.width is ast.Width.BIT:
                return f"byte {n}, bit {bit} of variable `{operand.name}`"
            return f"byte {n} of variable `{operand.name}`"
        case K.T | K.C | K.KT | K.KC | K.KB | K.KW | K.KP:
            return ""
        case _:
            assert_never(operand.kind)


def _line_of(analysis: Analysis, occurrence: Occurrence) -> str:
    span = occurrence.span
    text = analysis.text(span.file).split("\n")
    source = text[span.line - 1].split(";")[0].strip() if 0 < span.line <= len(text) else ""
    return f"line {span.line}: `{source}`"


def _declaration(analysis: Analysis, symbol: Symbol, what: str) -> str:
    places = analysis.index.definitions(symbol)
    if not places:
        return f"not declared {what}"
    decl = places[0].node
    size = f" ({decl.size} bytes)" if isinstance(decl, ast.VarDecl) else ""
    return f"[DECL] {_line_of(analysis, places[0])}{size}"


def _label(analysis: Analysis, symbol: Symbol) -> str:
    places = analysis.index.of(symbol)
    defined = [o for o in places if o.role is Role.DEFINE]
    jumps = [str(o.span.line) for o in places if o.role is Role.USE]
    label = defined[0].node if defined else None
    head = (f"label **{label.name}**, line {label.span.line}"
            if isinstance(label, ast.Label) and label.span
            else f"label **{symbol.name}** is not defined")
    return head + (f"; jumps to it from line {', '.join(jumps)}" if jumps else "")


def _block(analysis: Analysis, symbol: Symbol, node: object) -> str:
    firmware = FIRMWARE_BLOCKS.get(symbol.name)
    if firmware is not None:
        return (f"firmware block **{firmware.name}**: {firmware.description}\n\n"
                f"PSeg in: {firmware.inputs}\n\nPSeg out: {firmware.outputs}")
    declared = [o for o in analysis.index.of(symbol) if o.role is Role.DECLARE]
    if not declared:
        return f"function block **{symbol.name}** is not declared"
    decl = declared[0].node
    assert isinstance(decl, ast.FBDecl)
    return (f"function block **{decl.name}** in `{decl.file}`; "
            f"[DECL] {_line_of(analysis, declared[0])}")


def _slave(analysis: Analysis, symbol: Symbol) -> str:
    places = analysis.index.definitions(symbol)
    if not places:
        return f"slave {symbol.name} is not in [SETUP]"
    slave = places[0].node
    assert isinstance(slave, ast.SlaveSetup)
    parameter = "F" if slave.parameter is None else f"{slave.parameter:X}"
    return (f"[SETUP] {_line_of(analysis, places[0])}: I/O code {io_code_text(slave.io_code)}, "
            f"ID code {slave.id_code:X}h, power-up parameter {parameter}h")


#: What loads the constant register that S starts a timer or loads a counter with.
_PRESETS = (ast.OperandKind.KT, ast.OperandKind.KC, ast.OperandKind.KP)


def _timer_or_counter(analysis: Analysis, symbol: Symbol) -> str:
    """Its declaration, if it needs one, and the constants ``S`` starts or loads it with:
    the last ``L KT``/``KC``/``KP`` before each ``S T n`` (the constant register)."""
    n = int(symbol.name)
    is_timer = symbol.kind is SymbolKind.TIMER
    parts = []
    if n > 14:
        parts.append(_declaration(analysis, symbol, "timer" if is_timer else "counter"))
    presets: list[str] = []
    kind = ast.OperandKind.T if is_timer else ast.OperandKind.C
    for module in analysis.result.program.modules():
        constant: ast.Operand | None = None
        for statement in module.statements():
            if isinstance(statement, ast.Load) and statement.operand.kind in _PRESETS:
                constant = statement.operand
            elif (isinstance(statement, ast.Store) and statement.op is ast.StoreOp.SET
                  and statement.operand.kind is kind
                  and statement.operand.address == n and statement.span):
                value = str(constant) if constant else "no constant loaded before"
                presets.append(f"`{value}` (line {statement.span.line})")
    if presets:
        verb = "started with" if is_timer else "loaded with"
        parts.append(f"{verb} " + ", ".join(dict.fromkeys(presets)))
    return "\n\n".join(parts)
