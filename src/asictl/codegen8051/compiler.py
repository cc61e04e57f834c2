"""The compile pipeline: checked program -> allocation -> assembly -> machine code.

Conditional jumps are first written in their short form (``JC rel``, 2 bytes); when the
assembler finds one out of reach, that jump alone is rewritten as ``JNC skip / LJMP``
and the program assembled again, so code stays compact without guessing distances.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property

from asictl.codegen8051.allocate import allocate
from asictl.codegen8051.emitter import Emitter, Line, firmware_symbol
from asictl.codegen8051.generate import generate, symbols
from asictl.codes import CompileCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity
from asictl.il.ast import key
from asictl.il.loader import Program
from asictl.mcs51.asm_errors import Code
from asictl.mcs51.assembler import assemble
from asictl.mcs51.assembly import Assembly
from asictl.platform.master import Options
from asictl.runtime import layout
from asictl.runtime.line_map import LineMap
from asictl.runtime.program_map import ProgramMap
from asictl.source import SourceText, from_string

#: The name generated assembly goes by in listings and internal diagnostics.
GENERATED = "<generated>"
_MAX_RELAXATIONS = 16


@dataclass(frozen=True)
class Compiled:
    """A program translated to 8051 code, with everything needed to run and list it."""

    program: Program
    options: Options
    pmap: ProgramMap
    assembly: Assembly
    #: the generated assembly, line by line, with the IL span each line implements
    lines: tuple[Line, ...]
    entry_points: Mapping[str, int]
    #: assembler warnings, reported at the IL lines whose code they concern
    diagnostics: tuple[Diagnostic, ...] = ()

    @cached_property
    def code(self) -> bytes:
        """The code bytes from CODE_BASE up to the last one."""
        end = max((start + len(data) for start, data in self.assembly.segments), default=0)
        image = bytearray(max(0, end - layout.CODE_BASE))
        for start, data in self.assembly.segments:
            image[start - layout.CODE_BASE : start - layout.CODE_BASE + len(data)] = data
        return bytes(image)

    @cached_property
    def line_map(self) -> LineMap:
        """Which IL line each code byte implements (from the listing of the generated code)."""
        return LineMap.build(
            (entry.address, len(entry.data), self.lines[entry.span.line - 1].span)
            for entry in self.assembly.listing
            if entry.data and entry.address is not None and entry.span.file == GENERATED
        )

    @property
    def assembly_text(self) -> str:
        return "".join(f"{line.text}\n" for line in self.lines)

    def used_entry_points(self) -> dict[str, int]:
        """The firmware blocks the code refers to, by symbol, in generated or [ASSEMBLY] code.

        A master whose firmware has these blocks at these addresses can run the program.
        """
        code = "\n".join(line.text.partition(";")[0] for line in self.lines)
        names = "|".join(re.escape(firmware_symbol(name)) for name in self.entry_points)
        used = {key(m) for m in re.findall(rf"(?<![\w?])(?:{names})(?![\w?])", code, re.I)}
        return {
            name: address
            for name, address in sorted(self.entry_points.items())
            if key(firmware_symbol(name)) in used
        }


def compile_program(
    program: Program, *, entry_points: Mapping[str, int] | None = None
) -> Compiled:
    """Translate a program that has passed the checks. Raises ``DiagnosticError``."""
    entry_points = dict(entry_points or layout.default_entry_points())
    options = program.options
    pmap = allocate(program, map_counters=options.map_counters)
    if pmap.data_end > layout.DATA_LIMIT:
        raise DiagnosticError([_error(
            CompileCode.DATA_TOO_LARGE,
            f"the program's data needs {pmap.data_end - layout.DATA_BASE} bytes of RAM, "
            f"{layout.DATA_LIMIT - layout.DATA_BASE} are available"
        )])
    predefined = symbols(program, pmap, entry_points)
    long_jumps: frozenset[int] = frozenset()
    for _ in range(_MAX_RELAXATIONS):
        emitter = generate(program, pmap, entry_points, long_jumps)
        source = _source(emitter)
        try:
            assembly = assemble(source, predefined=predefined)
        except DiagnosticError as exc:
            far = {
                emitter.jump_lines[d.span.line - 1]
                for d in exc.diagnostics
                if d.code == Code.JUMP_TOO_FAR
                and d.span is not None
                and d.span.file == GENERATED
                and d.span.line - 1 in emitter.jump_lines
            }
            if far - long_jumps:
                long_jumps |= far
                continue
            raise DiagnosticError(_map_back(exc.diagnostics, emitter.lines)) from None
        break
    else:  # pragma: no cover - each round makes at least one more jump long
        raise AssertionError("jump relaxation did not settle")
    compiled = Compiled(
        program, options, pmap, assembly, tuple(emitter.lines), entry_points,
        tuple(_map_back(list(assembly.diagnostics), emitter.lines)),
    )
    end = layout.CODE_BASE + len(compiled.code)
    if end > layout.CODE_LIMIT:
        raise DiagnosticError([_error(
            CompileCode.CODE_TOO_LARGE,
            f"the program's code is {len(compiled.code)} bytes; at most "
            f"{layout.CODE_LIMIT - layout.CODE_BASE} fit"
        )])
    return compiled


def _source(emitter: Emitter) -> SourceText:
    return from_string(GENERATED, "".join(f"{line.text}\n" for line in emitter.lines))


def _error(code: CompileCode, message: str) -> Diagnostic:
    return Diagnostic(Severity.ERROR, code, message, None)


def _map_back(
    diagnostics: list[Diagnostic], lines: tuple[Line, ...] | list[Line]
) -> list[Diagnostic]:
    """Assembler findings on generated lines, reported at the IL line that produced them."""
    mapped: list[Diagnostic] = []
    for d in diagnostics:
        span = d.span
        if span is not None and span.file == GENERATED and 0 < span.line <= len(lines):
            line = lines[span.line - 1]
            message = f"{d.message} (in the assembly line '{line.text.strip()}')"
            mapped.append(Diagnostic(d.severity, d.code, message, line.span))
        else:
            mapped.append(d)
    return mapped
