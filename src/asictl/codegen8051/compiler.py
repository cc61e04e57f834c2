"""The compile pipeline: checked program -> allocation -> instructions -> machine code.

The instructions go into an output stream (``stream``), which chooses the form of each
conditional jump from the layout and assembles the objects as they are.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property

from asictl.codegen8051.allocate import allocate
from asictl.codegen8051.emitter import firmware_symbol
from asictl.codegen8051.generate import generate, symbols
from asictl.codegen8051.stream import GENERATED, Line
from asictl.codes import CompileCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity
from asictl.il.loader import Program
from asictl.mcs51.assembly import Assembly
from asictl.platform.master import Options
from asictl.runtime import layout
from asictl.runtime.line_map import LineMap
from asictl.runtime.program_map import ProgramMap

__all__ = ["GENERATED", "Compiled", "compile_program"]


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
    #: upper-case names of the symbols the code refers to (``OutputStream.references``)
    references: frozenset[str]
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
        return {
            name: address
            for name, address in sorted(self.entry_points.items())
            if firmware_symbol(name).upper() in self.references
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
    table = symbols(program, pmap, entry_points)
    output = generate(program, pmap, table).assemble(table)
    compiled = Compiled(
        program, options, pmap, output.assembly, output.lines, entry_points,
        output.references, output.diagnostics,
    )
    end = layout.CODE_BASE + len(compiled.code)
    if end > layout.CODE_LIMIT:
        raise DiagnosticError([_error(
            CompileCode.CODE_TOO_LARGE,
            f"the program's code is {len(compiled.code)} bytes; at most "
            f"{layout.CODE_LIMIT - layout.CODE_BASE} fit"
        )])
    return compiled


def _error(code: CompileCode, message: str) -> Diagnostic:
    return Diagnostic(Severity.ERROR, code, message, None)
