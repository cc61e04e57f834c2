"""The ``asictl`` command line: a thin click group over the library.

Subcommands are imported only when run, so ``asictl --help`` and shell completion stay
fast however heavy a command's dependencies are. Each command's one-line help is kept
here for the same reason.
"""

from __future__ import annotations

import gc
import importlib
import os
import sys
from typing import Any

import click

from asictl import __version__
from asictl.diagnostics import printable
from asictl.errors import ExitCode, UserError

#: name -> ("module:attribute", one-line help shown by ``asictl --help``)
COMMANDS: dict[str, tuple[str, str]] = {
    "compile": (
        "asictl.cli.compile:compile_", "Compile an IL program into an image for the master."
    ),
    "check": ("asictl.cli.check:check", "Check IL source files for errors (for CI and editors)."),
    "xref": (
        "asictl.cli.xref:xref", "Cross-reference: where each operand is read and written."
    ),
    "fmt": ("asictl.cli.fmt:fmt", "Lay out IL source files canonically (--check for CI)."),
    "lsp": ("asictl.cli.lsp:lsp", "Run the IL language server for editors (stdio)."),
    "dap": ("asictl.cli.dap:dap", "Run the IL debug adapter for editors (DAP on stdio)."),
    "asm": ("asictl.cli.asm:asm", "Assemble 8051 source into Intel HEX."),
    "disasm": ("asictl.cli.asm:disasm", "Disassemble an Intel HEX image into 8051 source."),
    "emu": ("asictl.cli.emu:emu", "Run an Intel HEX image on the 8051 emulator."),
    "download": (
        "asictl.cli.master:download_command", "Store a program in the master and load it."
    ),
    "upload": ("asictl.cli.master:upload_command", "Read the program back from the master."),
    "start": ("asictl.cli.master:start_command", "Start the master's control program."),
    "stop": ("asictl.cli.master:stop_command", "Stop the master's control program."),
    "reset": (
        "asictl.cli.master:reset_command", "Reload the master's program from its EEPROM."
    ),
    "status": (
        "asictl.cli.master:status_command",
        "Show the master's state: slaves' data, lists, flags, timers (ASI_MON's screens).",
    ),
    "sim": ("asictl.cli.sim:sim", "Run a program on an emulated master against a scenario."),
    "gateway": (
        "asictl.cli.gateway:gateway",
        "Serve the emulated AS-i/Modbus gateway (Modbus TCP/RTU); its front panel and keys.",
    ),
    "test": ("asictl.cli.sim:test", "Run every *.scenario.toml and report N passed, M failed."),
    "record": (
        "asictl.cli.record:record", "Record a running master's inputs and outputs as a scenario."
    ),
    "mutate": (
        "asictl.cli.mutate:mutate", "Mutation testing: would the scenarios notice a changed "
        "program?"
    ),
    "report": (
        "asictl.cli.report:report", "Merge the reports of a run's shards (--shard I/N) into one."
    ),
    "serve": (
        "asictl.cli.live:serve", "Keep an emulated board running in real time (a live board)."
    ),
    "bus": ("asictl.cli.live:bus", "The emulated AS-i cable: show, plug, unplug, match, inputs."),
    "slave": (
        "asictl.cli.commission:slave", "Change a slave's address, write its parameter, send "
        "it an AS-i command."
    ),
    "mode": ("asictl.cli.commission:mode", "Show or switch protected/configuration mode."),
    "store": (
        "asictl.cli.commission:store", "Store the actual configuration or parameters (F6/F5)."
    ),
    "setup": (
        "asictl.cli.commission:setup", "Write a program's [SETUP] as the projected configuration."
    ),
    "hiflags": (
        "asictl.cli.commission:hiflags",
        "Show or set the host interface flags: offline, data exchange, auto-address.",
    ),
    "diag": (
        "asictl.cli.commission:diag", "Read and clear LCS, error and telegram counters; the LOS."
    ),
    "emc": ("asictl.cli.emc:emc", "Run the PC2's EMC test mode (command 130) on slaves."),
    "write": ("asictl.cli.commission:write", "Write flags (F 10.0=1, FY 10=0x12) and outputs."),
    "force": (
        "asictl.cli.online:force", "Force inputs, outputs and flags (held every cycle); --list."
    ),
    "unforce": ("asictl.cli.online:unforce", "Release forced operands (--all: every one)."),
    "watch": (
        "asictl.cli.online:watch", "Watch operands or symbols on the master: a line per change."
    ),
    "verify": ("asictl.cli.verify:verify", "Compare a program with the one the master runs."),
    "probe": (
        "asictl.cli.probe:probe_command",
        "Read what a master tells without changing it, into a fixture (safe on a real one).",
    ),
    "monitor": ("asictl.cli.monitor:monitor", "A live full-screen view of the master (ASI_MON)."),
    "debug": ("asictl.cli.debug:debug", "Debug a program at the IL level on an emulated master."),
    "prove": (
        "asictl.cli.prove:prove", "Prove a program's properties for every input sequence."
    ),
    "diff": (
        "asictl.cli.diff:diff",
        "Compare two versions of a program network by network; --equivalent proves it.",
    ),
    "export": (
        "asictl.cli.export:export",
        "Export a program to S7 STL (AWL) for the PLC that replaces the master; --check.",
    ),
    "fleet": (
        "asictl.cli.fleet:fleet", "A plant's masters at once: back up into git, verify, status."
    ),
}


#: ``asictl --help`` in sections: title -> its commands, in the order shown. Every name of
#: ``COMMANDS`` is in exactly one section (tests/test_cli_help.py); a command added to
#: ``COMMANDS`` without a section is still listed, under "Other", until it gets one.
SECTIONS: dict[str, tuple[str, ...]] = {
    "Program": ("check", "xref", "fmt", "compile", "asm", "disasm", "emu"),
    "Master": ("download", "upload", "start", "stop", "reset", "status", "verify", "probe"),
    "Online": ("serve", "monitor", "watch", "write", "force", "unforce"),
    "Commissioning": ("bus", "slave", "mode", "store", "setup", "hiflags", "diag", "emc"),
    "Simulation and tests": ("sim", "test", "record", "mutate", "report", "debug"),
    "Verification": ("prove", "diff"),
    "Editors": ("lsp", "dap"),
    "Migration": ("export",),
    "Plant": ("fleet", "gateway"),
}


class LazyGroup(click.Group):
    """A group whose commands load on first use, and which turns failures into exit codes."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def resolve_command(
        self, ctx: click.Context, args: list[str]
    ) -> tuple[str | None, click.Command | None, list[str]]:
        """Click's own resolution; an unknown command names the closest known one."""
        try:
            return super().resolve_command(ctx, args)
        except click.exceptions.NoSuchCommand as exc:
            raise click.exceptions.NoSuchCommand(
                exc.command_name, possibilities=COMMANDS, ctx=ctx
            ) from None

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        entry = COMMANDS.get(cmd_name)
        if entry is None:
            return None
        module_name, _, attr = entry[0].partition(":")
        command = getattr(importlib.import_module(module_name), attr)
        assert isinstance(command, click.Command), entry[0]
        return command

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """The commands by section, their one-line help in one column across sections."""
        placed = {name for names in SECTIONS.values() for name in names}
        sections = [*SECTIONS.items(), ("Other", tuple(sorted(set(COMMANDS) - placed)))]
        width = max(map(len, COMMANDS))
        for title, names in sections:
            rows = [(name.ljust(width), COMMANDS[name][1]) for name in names if name in COMMANDS]
            if rows:
                with formatter.section(title):
                    formatter.write_dl(rows)

    def invoke(self, ctx: click.Context) -> Any:  # what the command returns, as click types it
        try:
            return super().invoke(ctx)
        except UserError as exc:
            click.echo(f"asictl: error: {printable(str(exc))}", err=True)
            ctx.exit(int(exc.exit_code))
        except (click.exceptions.Exit, click.ClickException, click.Abort):
            raise
        except KeyboardInterrupt:
            click.echo("asictl: interrupted", err=True)
            ctx.exit(130)
        except BrokenPipeError:
            # The reader of standard output went away ('asictl xref | head'): nothing to
            # report to it, and no traceback when the interpreter flushes at exit.
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
            ctx.exit(int(ExitCode.FAILED))
        except Exception as exc:
            if os.environ.get("ASICTL_DEBUG"):
                raise
            click.echo(
                f"asictl: internal error (this is a bug in asictl {__version__}): "
                f"{type(exc).__name__}: {printable(str(exc))}\n"
                "Set ASICTL_DEBUG=1 to see the traceback, and please report it.",
                err=True,
            )
            ctx.exit(int(ExitCode.BUG))


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="asictl")
def main() -> None:
    """Compile, check, download, upload and simulate AS-i Control II programs.

    'asictl COMMAND --help' describes one command, with examples; docs/commands.md
    describes them all.
    """


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())


def run() -> None:
    """The console script (and ``python -m asictl``): ``main``, and at the end the
    collector's view frozen. The interpreter's last collection at exit would otherwise
    walk every object a command left alive, for a process about to end: some 25 ms after
    checking a 10,000-line program. (Not in ``main``: tests call that in one process.)
    The program is named asictl however it was started, so that ``python -m asictl``
    shows the same usage lines and answers the same completion variable,
    ``_ASICTL_COMPLETE``."""
    try:
        main(prog_name="asictl")
    finally:
        gc.freeze()
