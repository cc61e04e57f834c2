"""Semantic checks: everything the master's compiler would refuse, and common mistakes.

The parser has already reported syntax; these checks see a whole ``Program`` (main file
plus the function blocks it calls) and report every problem at once, each at the exact
span of the offending operand or instruction. Ranges and rules follow the programming
manual and ``docs/language.md``; each diagnostic code is listed there.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import assert_never

from asictl.codes import CheckCode, SyntaxCode
from asictl.diagnostics import Diagnostic, Reporter, Span
from asictl.il import ast
from asictl.il.analysis import analyse
from asictl.il.ast import key
from asictl.il.collector import collector_paused
from asictl.il.foreign import operand_hint
from asictl.il.language import (
    BUILTIN_TC,
    MAX_IMAGE_NAME_BYTES,
    MAX_KT_MS,
    MAX_SOURCE_FILES,
    MAX_TC,
)
from asictl.il.loader import Program, Reader, calls, load_program
from asictl.il.pragmas import read_directives
from asictl.il.register import check_register
from asictl.mcs51.words import RESERVED as ASSEMBLER_RESERVED
from asictl.platform.master import Options
from asictl.readers.suggest import did_you_mean
from asictl.readers.units import TICK_MS, timer_ticks
from asictl.runtime.firmware import FIRMWARE_BLOCKS
from asictl.source import SourceText, read_source

CONST_RANGES = {
    ast.OperandKind.KT: MAX_KT_MS,
    ast.OperandKind.KC: 4095,
    ast.OperandKind.KB: 255,
    ast.OperandKind.KW: 65535,
}


#: A name that starts like an operand mark followed by digits reads as that operand.
_OPERAND_LOOKALIKE = re.compile(
    r"(I2B|IB|QB|FY|FW|KT|KC|KP|KB|KW|PSEG|I|Q|F|T|C)(\d+)", re.IGNORECASE
)


class Dialect(StrEnum):
    CONTROL2 = "control2"
    CONTROL1 = "control1"


@dataclass
class _Scope:
    """What a module's operands may refer to: declared timers, counters and variables."""

    timers: set[int]
    counters: set[int]
    variables: dict[str, ast.VarDecl]


def check_program(
    program: Program,
    dialect: Dialect = Dialect.CONTROL2,
    *,
    read_errors: Sequence[Diagnostic] = (),
) -> list[Diagnostic]:
    """All semantic diagnostics of a loaded program, in source order.

    ``read_errors`` are the errors met loading it: lines the reader skipped leave gaps
    the checks must not take for mistakes of their own (no cascades), and a program with
    errors gets no analyses (``il.analysis``). Warnings that ``asictl:`` comments silence
    are left out (``il.pragmas``).
    """
    report = Reporter()
    skipped = _skipped_lines(program, read_errors)
    scope = _declarations(program, report)
    _check_main_only_sections(program, report)
    for module in program.modules():
        lines = skipped.get(module.file, [])
        _check_options(module, report)
        _check_setup(module, report)
        _check_code(module, scope, report)
        _check_labels_and_jumps(module, report, _lost_labels(program, module.file, lines))
        _check_calls(module, program, report)
        check_register(module, report, lines)
        if dialect is Dialect.CONTROL1:
            _check_control1(module, scope, report)
    _check_duplicate_slaves(program, report)
    _check_recursion(program, report)
    _check_image_limits(program, report)
    directives = read_directives(program.sources)
    if not report.has_errors and not any(d.is_error for d in read_errors):
        analyse(program, directives, report)
    diagnostics = directives.apply([*report.diagnostics, *directives.problems])
    return sorted(diagnostics, key=Diagnostic.sort_key)


def _skipped_lines(program: Program, errors: Sequence[Diagnostic]) -> dict[str, list[int]]:
    """File -> the lines a syntax error made the reader skip, in order."""
    skipped: dict[str, set[int]] = {}
    codes = set(SyntaxCode)
    for error in errors:
        if error.code in codes and error.span is not None:
            skipped.setdefault(error.span.file, set()).add(error.span.line)
    return {file: sorted(lines) for file, lines in skipped.items()}


_LEADING_NAME = re.compile(r"[ \t]*([A-Za-z_][A-Za-z0-9_]*)")


def _lost_labels(program: Program, file: str, lines: Sequence[int]) -> set[str]:
    """Names that may have been labels on skipped lines (``loop A I 1.0`` lacks its ':',
    ``x: A Z`` lost its label with the line): jumps to them are not reported again."""
    source = program.sources.get(file)
    if source is None:
        return set()
    text = source.text.split("\n")
    names = set()
    for line in lines:
        match = _LEADING_NAME.match(text[line - 1]) if 0 < line <= len(text) else None
        if match:
            names.add(key(match[1]))
    return names


# ----------------------------------------------------------------------- the image


def _check_image_limits(program: Program, report: Reporter) -> None:
    """What the image format cannot store, found here so that ``compile`` refuses nothing
    that ``check`` passed: at most 255 source files, each under its own base name."""
    decl_of_file = {
        module.file: program.fb_decls.get(name) for name, module in program.blocks.items()
    }
    names: dict[str, str] = {}
    for number, file in enumerate(program.sources, start=1):
        decl = decl_of_file.get(file)
        span = decl.span if decl is not None else None
        if number == MAX_SOURCE_FILES + 1:
            report.error(
                CheckCode.TOO_MANY_FILES,
                f"the program has {len(program.sources)} source files (the main file and "
                f"its function-block files); an image holds at most {MAX_SOURCE_FILES}",
                span,
            )
        base = Path(file).name or file
        if base in names:
            report.error(
                CheckCode.DUPLICATE_FILE_NAME,
                f"function-block file '{file}' has the same name as '{names[base]}'; "
                "an image stores source files by name: rename one",
                span,
            )
        names.setdefault(base, file)


# ----------------------------------------------------------------------- declarations


def _declarations(program: Program, report: Reporter) -> _Scope:
    scope = _Scope(timers=set(), counters=set(), variables={})
    seen: dict[str, Span | None] = {}
    for module in program.modules():
        for section in module.sections_of(ast.DeclSection):
            for decl in section.declarations:
                if isinstance(decl, ast.TimerDecl | ast.CounterDecl):
                    kind = "timer" if isinstance(decl, ast.TimerDecl) else "counter"
                    target = scope.timers if kind == "timer" else scope.counters
                    if decl.number > MAX_TC:
                        report.error(
                            CheckCode.OUT_OF_RANGE,
                            f"{kind} number {decl.number} out of range 0..{MAX_TC}",
                            decl.span,
                        )
                    elif decl.number < BUILTIN_TC:
                        report.warning(
                            CheckCode.BUILTIN_DECLARED,
                            f"{kind} {decl.number} always exists; only numbers above 14 "
                            "need a declaration",
                            decl.span,
                        )
                    if decl.number in target:
                        report.error(
                            CheckCode.DUPLICATE_DECLARATION,
                            f"{kind} {decl.number} declared twice", decl.span)
                    target.add(decl.number)
                    continue
                name = key(decl.name)
                if isinstance(decl, ast.VarDecl | ast.FBDecl) and name in FIRMWARE_BLOCKS:
                    report.error(
                        CheckCode.DUPLICATE_DECLARATION,
                        f"'{decl.name}' is the name of a firmware function block",
                        decl.span,
                    )
                elif name in seen:
                    first = seen[name]
                    where = f" (first declared at {first})" if first else ""
                    report.error(
                        CheckCode.DUPLICATE_DECLARATION,
                        f"'{decl.name}' declared twice{where}", decl.span,
                        _note(first, "first declared here"),
                    )
                seen.setdefault(name, decl.span)
                if isinstance(decl, ast.VarDecl):
                    if decl.name.upper() in ASSEMBLER_RESERVED:
                        report.error(
                            CheckCode.OPERAND_LIKE_NAME,
                            f"variable '{decl.name}' is named like an 8051 register or "
                            "assembler word; the program's assembly could not refer to it",
                            decl.span,
                        )
                    shadow = _OPERAND_LOOKALIKE.match(decl.name)
                    if shadow:
                        report.error(
                            CheckCode.OPERAND_LIKE_NAME,
                            f"variable '{decl.name}' cannot be used as an operand: "
                            f"'{decl.name} 0' reads as '{shadow[1].upper()} {shadow[2]}'",
                            decl.span,
                        )
                    size = len(decl.name.encode("utf-8"))
                    if size > MAX_IMAGE_NAME_BYTES:
                        report.error(
                            CheckCode.NAME_TOO_LONG,
                            f"variable name of {size} bytes; the image stores names of at "
                            f"most {MAX_IMAGE_NAME_BYTES}",
                            decl.span,
                        )
                    if not 1 <= decl.size <= 255:
                        report.error(
                            CheckCode.OUT_OF_RANGE,
                            f"variable size {decl.size} out of range 1..255 bytes",
                            decl.span,
                        )
                    scope.variables.setdefault(name, decl)
    return scope


def _check_main_only_sections(program: Program, report: Reporter) -> None:
    for block in program.blocks.values():
        for section in block.sections:
            if isinstance(section, ast.OptionsSection | ast.SetupSection | ast.RawSection):
                report.error(
                    CheckCode.MISPLACED_SECTION,
                    f"[{section.kind.value}] belongs in the main program file, "
                    "not in a function block's file",
                    section.span,
                )
    main = program.main
    if main.sections_of(ast.RawSection) and any(
        isinstance(s, ast.ProgramSection | ast.GatingSection | ast.AssemblySection)
        for s in main.sections
    ):
        raw = main.sections_of(ast.RawSection)[0]
        report.error(
            CheckCode.MISPLACED_SECTION,
            "[RAW] holds a whole uploaded image and cannot be combined with program sections",
            raw.span,
        )


# ---------------------------------------------------------------------- options/setup


def _note(span: Span | None, message: str) -> list[tuple[Span, str]]:
    """A related location for a diagnostic, when the place is known."""
    return [(span, message)] if span else []


def _check_options(module: ast.Module, report: Reporter) -> None:
    seen: dict[str, ast.Option] = {}
    for section in module.sections_of(ast.OptionsSection):
        for option in section.options:
            name = key(option.name)
            if name not in Options.NAMES:
                report.error(
                    CheckCode.UNKNOWN_OPTION,
                    f"unknown option '{option.name}'{did_you_mean(option.name, Options.NAMES)} "
                    f"(known: {', '.join(Options.NAMES)})",
                    option.span,
                )
            elif name in seen:
                report.warning(
                    CheckCode.DUPLICATE_OPTION,
                    f"option '{option.name}' given again", option.span,
                    _note(seen[name].span, "first given here"),
                )
            seen.setdefault(name, option)


def _check_setup(module: ast.Module, report: Reporter) -> None:
    for section in module.sections_of(ast.SetupSection):
        for slave in section.slaves:
            if not 1 <= slave.address <= 31:
                report.error(
                    CheckCode.BAD_SETUP,
                    f"slave address {slave.address} out of range 1..31 "
                    "(address 0 is reserved for new slaves)",
                    slave.span,
                )
            for what, value in (
                ("I/O code", slave.io_code),
                ("ID code", slave.id_code),
                ("parameter", slave.parameter),
            ):
                if value is not None and not 0 <= value <= 0xF:
                    report.error(
                        CheckCode.BAD_SETUP,
                        f"{what} {value} out of range 0..F (one hex digit)", slave.span
                    )


def _check_duplicate_slaves(program: Program, report: Reporter) -> None:
    first: dict[int, ast.SlaveSetup] = {}
    for section in program.main.sections_of(ast.SetupSection):
        for slave in section.slaves:
            if slave.address in first:
                report.error(
                    CheckCode.DUPLICATE_SLAVE,
                    f"slave {slave.address} is already set up at {first[slave.address].span}",
                    slave.span,
                    _note(first[slave.address].span, "first set up here"),
                )
            else:
                first[slave.address] = slave


# --------------------------------------------------------------------------- operands


def _check_code(module: ast.Module, scope: _Scope, report: Reporter) -> None:
    for node in module.code():
        uses = ast.operands(node)
        if not uses:
            continue
        for operand, _ in uses:
            _check_operand(operand, scope, report)
        if isinstance(node, ast.Store):
            target = node.operand if node.op is ast.StoreOp.ASSIGN else None
        else:
            target = node.target if isinstance(node, ast.GatingLine) else None
        if target is not None and target.kind in _TIMER_OR_COUNTER:
            report.error(
                CheckCode.ASSIGNED_TIMER_OR_COUNTER,
                f"the status bit of {target} is read-only: S {target} loads it, "
                f"R {target} clears it",
                target.span,
            )
        if isinstance(node, ast.Load) and node.operand.kind is ast.OperandKind.KT:
            const = node.operand
            if const.address % 10 and const.address <= MAX_KT_MS:
                rounded = timer_ticks(const.address) * TICK_MS
                report.warning(
                    CheckCode.TIME_ROUNDED,
                    f"timers count in 10 ms steps: KT {const.address} is rounded up to "
                    f"{rounded} ms",
                    const.span,
                )


_TIMER_OR_COUNTER = (ast.OperandKind.T, ast.OperandKind.C)


def _range(
    report: Reporter, span: Span | None, what: str, value: int, hi: int, lo: int = 0
) -> None:
    if not lo <= value <= hi:
        report.error(CheckCode.OUT_OF_RANGE, f"{what} {value} out of range {lo}..{hi}", span)


def _check_operand(operand: ast.Operand, scope: _Scope, report: Reporter) -> None:
    kind, n, span = operand.kind, operand.address, operand.span
    K = ast.OperandKind
    match kind:
        case K.F:
            _range(report, span, "flag byte", n, 127)
            _range(report, span, "flag bit", operand.bit, 7)
        case K.I | K.I2 | K.Q:
            _range(report, span, "slave address", n, 31)
            _range(report, span, "data bit", operand.bit, 3)
        case K.T | K.C:
            is_timer = kind is K.T
            what = "timer" if is_timer else "counter"
            declared = scope.timers if is_timer else scope.counters
            if not 0 <= n <= MAX_TC:
                _range(report, span, f"{what} number", n, MAX_TC)
            elif n >= BUILTIN_TC and n not in declared:
                report.error(
                    CheckCode.UNDECLARED_TIMER_OR_COUNTER,
                    f"{what} {n} is not declared (only 0..14 exist without "
                    f"'{kind.value}{n} {what.upper()}' in [DECL])",
                    span,
                )
        case K.VAR:
            decl = _variable(operand.name, span, scope, report)
            if decl:
                _range(report, span, f"byte of '{decl.name}'", n, decl.size - 1)
            if operand.width is ast.Width.BIT:
                _range(report, span, "bit", operand.bit, 7)
        case K.FY:
            _range(report, span, "flag byte", n, 127)
        case K.PSEG:
            _range(report, span, "PSeg byte", n, 15)
        case K.IB | K.I2B | K.QB:
            _range(report, span, f"{kind.value} slave address", n, 30)
            if n % 2:
                report.error(
                    CheckCode.ODD_SLAVE_ADDRESS,
                    f"{kind.value} takes an even slave address (the byte holds slaves "
                    f"{n - 1} and {n} as {kind.value} {n - 1})",
                    span,
                )
        case K.FW:
            _range(report, span, "flag word", n, 126)
        case K.KT | K.KC | K.KB | K.KW:
            _range(report, span, kind.value, n, CONST_RANGES[kind])
        case K.KP:
            _range(report, span, "KP slave address", n, 31)
            _range(report, span, "KP parameter", operand.bit, 15)
        case _:
            assert_never(kind)


def _variable(
    name: str, span: Span | None, scope: _Scope, report: Reporter
) -> ast.VarDecl | None:
    decl = scope.variables.get(key(name))
    if decl is None:
        german = operand_hint(name)
        hint = (f" ({german})" if german
                else did_you_mean(name, [d.name for d in scope.variables.values()]))
        report.error(
            CheckCode.UNDECLARED_VARIABLE, f"'{name}' is not a declared variable{hint}", span)
    return decl


# ------------------------------------------------------------------ labels and calls


def _check_labels_and_jumps(module: ast.Module, report: Reporter, lost: set[str]) -> None:
    labels: dict[str, ast.Label] = {}
    for statement in module.statements():
        if isinstance(statement, ast.Label):
            name = key(statement.name)
            if name in labels:
                report.error(
                    CheckCode.DUPLICATE_LABEL,
                    f"label '{statement.name}' already defined at {labels[name].span}",
                    statement.span,
                    _note(labels[name].span, "first defined here"),
                )
            else:
                labels[name] = statement
    for statement in module.statements():
        if (
            isinstance(statement, ast.Jump)
            and key(statement.label) not in labels
            and key(statement.label) not in lost
        ):
            report.error(
                CheckCode.UNKNOWN_LABEL,
                f"jump to undefined label '{statement.label}'"
                f"{did_you_mean(statement.label, [s.name for s in labels.values()])} "
                "(labels are local to the main program or one function block)",
                statement.span,
            )


def _check_calls(module: ast.Module, program: Program, report: Reporter) -> None:
    for call in calls(module):
        name = key(call.name)
        if name not in FIRMWARE_BLOCKS and name not in program.fb_decls:
            known = [d.name for d in program.fb_decls.values()]
            known += [b.name for b in FIRMWARE_BLOCKS.values()]
            report.error(
                CheckCode.UNKNOWN_BLOCK,
                f"function block '{call.name}' is not declared{did_you_mean(call.name, known)} "
                f"(declare it in [DECL] as '{call.name} FB <file>')",
                call.span,
            )


def _check_recursion(program: Program, report: Reporter) -> None:
    """Function blocks may not call themselves, directly or through others."""
    graph = {
        name: [c for c in calls(module) if key(c.name) in program.blocks]
        for name, module in program.blocks.items()
    }
    reported: set[str] = set()
    state: dict[str, int] = {}  # 1 on the stack, 2 done

    def visit(name: str, path: list[str]) -> None:
        state[name] = 1
        for call in graph.get(name, []):
            callee = key(call.name)
            if state.get(callee) == 1:
                cycle = [*path[path.index(callee) :], callee] if callee in path else [callee]
                if callee not in reported:
                    reported.add(callee)
                    names = " -> ".join(program.fb_decls[n].name for n in cycle)
                    report.error(
                        CheckCode.RECURSION, f"recursive function block call: {names}", call.span)
            elif state.get(callee) is None:
                visit(callee, [*path, callee])
        state[name] = 2

    for call in calls(program.main):
        name = key(call.name)
        if name in program.blocks and state.get(name) is None:
            visit(name, [name])


# ------------------------------------------------------------------------ dialects


def _check_control1(module: ast.Module, scope: _Scope, report: Reporter) -> None:
    """Report what AS-i Control I cannot run (features marked "AS-i Control II only")."""

    def only2(what: str, span: Span | None) -> None:
        report.error(CheckCode.CONTROL2_ONLY, f"{what} is AS-i Control II only", span)

    for section in module.sections:
        if isinstance(section, ast.DeclSection):
            only2("a [DECL] section", section.span)
        elif isinstance(section, ast.AssemblySection):
            only2("an [ASSEMBLY] section", section.span)
        elif isinstance(section, ast.RawSection):
            only2("a [RAW] section", section.span)
    for statement in module.statements():
        match statement:
            case ast.CallFB(span=span):
                only2("calling a function block", span)
            case ast.Asm(span=span):
                only2("the ASM operator", span)
            case ast.BlockEnd(kind=ast.EndKind.BEU, span=span):
                only2("BEU", span)
            case ast.Arith(span=span) | ast.Compare(span=span):
                only2(f"byte operation '{statement.to_source()}'", span)
            case ast.Load(operand=op, span=span) | ast.Transfer(operand=op, span=span):
                if not _control1_operand(op, statement):
                    only2(f"byte/word operation '{statement.to_source()}'", span)
            case (ast.Logic() | ast.Store() | ast.Not() | ast.Count() | ast.SegmentEnd()
                  | ast.BlockEnd() | ast.Jump() | ast.Param() | ast.Label()):
                pass
            case _:
                assert_never(statement)
    for node in module.code():
        for operand, _ in ast.operands(node):
            if operand.kind is ast.OperandKind.VAR:
                only2("a declared variable", operand.span)
            elif operand.kind in _TIMER_OR_COUNTER and operand.address >= BUILTIN_TC:
                what = "timer" if operand.kind is ast.OperandKind.T else "counter"
                only2(f"{what} {operand.address} (Control I has 0..14)", operand.span)


def _control1_operand(operand: ast.Operand, statement: ast.Statement) -> bool:
    """Control I loads KT, KC and KP constants and moves timer and counter words (3.4.3)."""
    kind = operand.kind
    if kind in _TIMER_OR_COUNTER or kind is ast.OperandKind.KP:
        return True
    return isinstance(statement, ast.Load) and kind in (ast.OperandKind.KT, ast.OperandKind.KC)


@dataclass
class CheckResult:
    """A loaded program and every diagnostic about it, load and semantic, in source order."""

    program: Program
    diagnostics: list[Diagnostic]

    @property
    def has_errors(self) -> bool:
        return any(d.is_error for d in self.diagnostics)


def check_source(
    source: SourceText, *, dialect: Dialect = Dialect.CONTROL2, lib: Iterable[str | Path] = (),
    read: Reader = read_source, exists: Callable[[Path], bool] = Path.is_file,
) -> CheckResult:
    """Read a main file and the blocks it calls, and check the whole program.

    ``read`` and ``exists`` stand for the file system (an editor's open buffers).
    """
    with collector_paused():  # see asictl.il.collector
        program, load_diagnostics = load_program(source, lib=lib, read=read, exists=exists)
        diagnostics = [
            *load_diagnostics, *check_program(program, dialect, read_errors=load_diagnostics)
        ]
    return CheckResult(program, sorted(diagnostics, key=Diagnostic.sort_key))
