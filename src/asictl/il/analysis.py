"""The analyses of a program that checked clean: wiring (W70x) and logic (W71x).

They run after the checks, and only on a program without errors: on a program the
reader or the checks could not take in whole, they would report the gaps the errors
left (a flag whose writing line did not parse is "never written").

A main file with neither [OPTIONS] nor [SETUP] is taken for a fragment, as the manual's
examples are: a few lines to show an instruction, whose flags and slaves belong to a
program around them. The analyses that need the whole program (the wiring, and flags
read but never written) leave fragments alone; the others apply to every file.
"""

from __future__ import annotations

from asictl.diagnostics import Reporter
from asictl.il import ast
from asictl.il.loader import Program
from asictl.il.logic import check_logic
from asictl.il.pragmas import Directives
from asictl.il.usage import usage_of
from asictl.il.wiring import check_wiring


def is_whole_program(main: ast.Module) -> bool:
    """A main file that configures a master ([OPTIONS] or [SETUP]), not a fragment."""
    return any(isinstance(s, ast.OptionsSection | ast.SetupSection) for s in main.sections)


def analyse(program: Program, directives: Directives, report: Reporter) -> None:
    index = usage_of(program)
    whole = is_whole_program(program.main)
    if whole:
        check_wiring(program, index, report)
    check_logic(
        program, index, report, whole_program=whole,
        host_flags=[flag for flag, _ in directives.host_flags],
    )
