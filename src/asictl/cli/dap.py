"""``asictl dap``: the debug adapter, speaking the Debug Adapter Protocol on stdin/stdout."""

from __future__ import annotations

import sys

import click

from asictl.cli.options import lib_option


@click.command()
@lib_option
def dap(lib: tuple[str, ...]) -> None:
    """Run the debug adapter on stdin/stdout (editors start it; see docs/editors.md).

    'launch' debugs a program on an emulated master in virtual time (with its scenario,
    or none, and --set-style inputs); 'attach' debugs the program of a live emulated
    board ('asictl serve'). Breakpoints on IL lines with conditions (RLO == 1, FY 10 > 3)
    and hit counts, step over, into and out of function blocks, a step of one program
    cycle, the registers, inputs, outputs, flags, timers, counters and symbols, shown
    and set.

    An editor runs the command below; a launch configuration (VS Code's, or nvim-dap's
    adapter) names it with "type": "asictl", "request": "launch", "program": "${file}".

    \b
    Examples:
      asictl dap
      asictl dap --lib blocks
    """
    from asictl.dap.main import run

    run(sys.stdin.buffer, sys.stdout.buffer, lib)
