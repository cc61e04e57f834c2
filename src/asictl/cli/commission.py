"""ASI_MON's editor mode on the command line: slave addresses, parameters, AS-i commands,
the operation mode, storing the actual configuration and parameters, the projected
configuration, diagnostics, flags and outputs (docs/commissioning.md).

Every command goes through the master's host commands (host/commissioning.py), so it
works on an emulated board, a live one, a real board and, where the gateway offers the
function, through Modbus. Refusals name the ASI_CTRL STATUS word.
"""

from __future__ import annotations

import json
import re
from dataclasses import asdict
from typing import Unpack

import click

from asictl.cli.board_options import BoardOptions, board_options, open_master
from asictl.cli.guard_options import real_master_option
from asictl.cli.options import lib_option, one_of
from asictl.errors import ExitCode, UserError
from asictl.host.commissioning import image_writes, write_flags
from asictl.host.emulated.actions import parse_address, parse_number
from asictl.host.master import Master
from asictl.host.overwrite_guard import check_overwrite
from asictl.host.symbols import Names
from asictl.source import check_readable

# --------------------------------------------------------------------------- slave


@click.group("slave")
def slave() -> None:
    """A slave's address, parameter, or an AS-i command to it.

    \b
    Examples:
      asictl bus plug 0 iiio,1
      asictl slave address 0 5
    """


@slave.command("address")
@click.argument("old")
@click.argument("new")
@board_options
@real_master_option
def address(old: str, new: str, real_master: bool, **board: Unpack[BoardOptions]) -> None:
    """Give the slave at OLD the address NEW (0 is a new slave's address).

    The master's command 20: the slave must be detected at OLD, NEW must be free, and no
    other slave may have address 0. A refusal says why: STATUS 83A1h (no slave at OLD),
    83A2h (a slave 0 is present), 83A3h (NEW is taken), 83A4h..83A6h (the slave could not
    be re-addressed).

    Exit status: 0 done, 1 refused, 2 bad usage.

    \b
    Examples:
      asictl bus plug 0 iiio,1
      asictl slave address 0 5
    """
    before, after = parse_address(old), parse_address(new)
    with open_master(**board) as master:
        check_overwrite(master, f"re-address slave {before}", real_master=real_master)
        master.tools().change_address(before, after)
        click.echo(f"{master.name}: slave {before} now has address {after}", err=True)


@slave.command("parameter")
@click.argument("address_", metavar="ADDRESS")
@click.argument("value")
@board_options
@real_master_option
def parameter(
    address_: str, value: str, real_master: bool, **board: Unpack[BoardOptions]
) -> None:
    """Write parameter VALUE (0..15) to the slave at ADDRESS (Write_Parameter, command 5);
    prints the slave's answer. The permanent parameter (PP) stays: 'asictl store
    parameters' makes the actual ones permanent.

    \b
    Examples:
      asictl bus plug 5 iiio,1
      asictl slave parameter 5 0b0111
    """
    where = parse_address(address_, zero=False)
    parameter_value = parse_number(value, "parameter", 15)
    with open_master(**board) as master:
        check_overwrite(master, f"write a parameter to slave {where}", real_master=real_master)
        answer = master.tools().write_parameter(where, parameter_value)
    click.echo(f"{answer:X}h")
    click.echo(
        f"{master.name}: slave {where} got parameter {parameter_value:X}h, answered {answer:X}h",
        err=True,
    )
    _lost_note(master, "the next command starts the slaves again with their permanent "
                       "parameters, so 'asictl store parameters' then stores those, not "
                       f"{parameter_value:X}h")


def _lost_note(master: Master, what: str) -> None:
    """Say what a change to an emulated board nobody serves does not keep: such a board
    runs only during a command."""
    if master.action is not None and master.action.live is None:
        click.echo(f"{master.name}: note: this emulated board runs only during a command: "
                   f"{what} ('asictl serve' keeps it running)", err=True)


@slave.command("command")
@click.argument("address_", metavar="ADDRESS")
@click.argument("information")
@board_options
@real_master_option
def command(
    address_: str, information: str, real_master: bool, **board: Unpack[BoardOptions]
) -> None:
    """Send the AS-i command call INFORMATION (0..1Fh, e.g. 10h read I/O configuration,
    11h read ID code, 1Ch reset slave, 1Eh read status) to the slave at ADDRESS (Execute
    Command, 22); prints the slave's answer.

    \b
    Examples:
      asictl bus plug 5 iiio,1
      asictl slave command 5 11h
    """
    where = parse_address(address_)
    info = parse_number(information, "AS-i command", 0x1F)
    with open_master(**board) as master:
        check_overwrite(master, f"send an AS-i command to slave {where}",
                        real_master=real_master)
        answer = master.tools().execute_command(where, info)
    click.echo(f"{answer:X}h")


# --------------------------------------------------------------------------- mode, store


@click.command("mode")
@click.argument("mode", required=False, type=click.Choice(["protected", "configuration"]))
@board_options
@real_master_option
def mode(mode: str | None, real_master: bool, **board: Unpack[BoardOptions]) -> None:
    """Show or switch the operation mode (command 17). In configuration mode the master
    activates every slave it finds; in protected mode only the projected ones. Protected
    mode is refused while a slave with address 0 is present (STATUS 8385h).

    \b
    Examples:
      asictl mode configuration
      asictl mode
    """
    with open_master(**board) as master:
        if mode is not None:
            check_overwrite(master, f"switch to {mode} mode", real_master=real_master)
            master.tools().set_mode(configuration=mode == "configuration")
        now = master.status().mode
    click.echo(f"{master.name}: {now} mode", err=True)


@click.command("store")
@click.argument("what", type=click.Choice(["configuration", "parameters"]))
@board_options
@real_master_option
def store(what: str, real_master: bool, **board: Unpack[BoardOptions]) -> None:
    """Store the actual configuration (the detected slaves become LPS and PCD; command
    10, configuration mode only: ASI_MON's F6) or the actual parameters (PI becomes PP;
    command 7: ASI_MON's F5).

    \b
    Examples:
      asictl bus plug 5 iiio,1
      asictl mode configuration
      asictl store configuration
      asictl store parameters
    """
    with open_master(**board) as master:
        check_overwrite(master, f"store the actual {what}", real_master=real_master)
        tools = master.tools()
        if what == "configuration":
            tools.store_configuration()
        else:
            tools.store_parameters()
    click.echo(f"{master.name}: stored the actual {what}", err=True)


@click.command("setup")
@click.argument("file", metavar="FILE.asi|FILE.hex", type=click.Path(dir_okay=False))
@board_options
@real_master_option
@lib_option
def setup(
    file: str, real_master: bool, lib: tuple[str, ...], **board: Unpack[BoardOptions]
) -> None:
    """Write the projected configuration (LPS, PCD, PP, and PI) of FILE's [SETUP] to the
    master without downloading its program, as a download does first. FILE is built as
    'asictl download' builds it.

    \b
    Example:
      asictl setup demos/blink.asi
    """
    from asictl.build import build_file

    check_readable(file)  # before a board is opened: a missing one would be created
    with open_master(**board) as master:
        check_overwrite(master, "write the projected configuration", real_master=real_master)
        built = build_file(file, entry_points=master.transport.entry_points(), lib=lib)
        click.echo(built.render(), nl=False, err=True)
        if built.has_errors or built.image is None:
            raise UserError(f"{file}: not written: the program has errors", ExitCode.FAILED)
        configuration = built.image.configuration
        master.tools().set_configuration(configuration)
        projected = configuration.projected()
    click.echo(
        f"{master.name}: projected slaves {', '.join(map(str, projected)) or '(none)'}", err=True
    )


# --------------------------------------------------------------------------- hi-flags


def _on_off(chosen: str | None, sets: str) -> bool | None:
    """A hi-flag bit as a pair of flags asks for it: None when neither was given."""
    return None if chosen is None else chosen == sets


@click.command("hiflags")
@click.option("--offline", is_flag=True,
              help="Take the master offline (no AS-i communication at all).")
@click.option("--online", is_flag=True, help="Take the master online again.")
@click.option("--data-exchange", is_flag=True,
              help="Let the master exchange data with the slaves.")
@click.option("--no-data-exchange", is_flag=True,
              help="Stop the data exchange (the slaves keep their last outputs until their "
              "watchdogs end them).")
@click.option("--auto-address", is_flag=True,
              help="Let the master give a replaced slave its address automatically.")
@click.option("--no-auto-address", is_flag=True,
              help="Do not give a replaced slave its address automatically.")
@click.option("--json", "as_json", is_flag=True, help="The flags as JSON on stdout.")
@board_options
@real_master_option
def hiflags(
    offline: bool, online: bool, data_exchange: bool, no_data_exchange: bool,
    auto_address: bool, no_auto_address: bool, as_json: bool, real_master: bool,
    **board: Unpack[BoardOptions],
) -> None:
    """Show or set the host interface flags (ASI_MON's hi-flags; the PC2 driver's message
    74h, 'write host interface flags'): offline, data exchange active, auto-address
    enable. The master reads them every AS-i cycle. Without an option they are shown;
    'status --json' has them as 'hi_flags' (bit 0 data exchange off, 1 offline, 2 auto
    address off: bits 0 and 2 are transmitted inverted).

    Exit status: 0 shown or set, 1 the master did not take them, 2 bad usage.

    \b
    Examples:
      asictl hiflags --offline
      asictl hiflags --online --no-auto-address
    """
    from asictl.host.status import hi_flag_text
    from asictl.platform.pc2 import HiFlag

    # each bit: set, cleared or (neither flag given) left as it is; both are a usage error
    wanted = {
        HiFlag.OFFLINE: _on_off(one_of(offline=offline, online=online), "offline"),
        HiFlag.DATA_EXCHANGE_OFF: _on_off(one_of(
            data_exchange=data_exchange, no_data_exchange=no_data_exchange),
            "no_data_exchange"),
        HiFlag.AUTO_ADDRESS_OFF: _on_off(one_of(
            auto_address=auto_address, no_auto_address=no_auto_address), "no_auto_address"),
    }
    with open_master(**board) as master:
        tools = master.tools()
        flags = before = tools.read_hi_flags()
        for bit, on in wanted.items():
            if on is not None:
                flags = flags | bit if on else flags & ~bit
        if flags != before:
            check_overwrite(master, "write the hi-flags", real_master=real_master)
            tools.write_hi_flags(flags)
            master.settle()
            flags = tools.read_hi_flags()
        summary = master.summary()
    if as_json:
        click.echo(json.dumps({
            "hi_flags": flags, "offline": bool(flags & HiFlag.OFFLINE),
            "data_exchange_active": not flags & HiFlag.DATA_EXCHANGE_OFF,
            "auto_address_enable": not flags & HiFlag.AUTO_ADDRESS_OFF,
        }, indent=2))
    else:
        click.echo(f"hi-flags {flags:02X}h {hi_flag_text(flags)}")
    click.echo(f"{master.name}: {summary}", err=True)
    if flags != before:
        _lost_note(master, "the hi-flags are in its DPRAM and start again at 00h with the "
                           "next command")


# --------------------------------------------------------------------------- diagnostics


def _list(text: str) -> list[int]:
    if text.strip() in ("", "none"):
        return []
    return [parse_address(part) for part in re.split(r"[,\s]+", text.strip()) if part]


@click.command("diag")
@board_options
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
@click.option(
    "--set-los", metavar="LIST",
    help="First set the list of offline slaves (command 72): addresses such as '3,17', or "
    "'none'. A configuration error at one of them takes the master offline.",
)
@real_master_option
def diag(
    as_json: bool, set_los: str | None, real_master: bool, **board: Unpack[BoardOptions]
) -> None:
    """Read and clear the AS-i diagnostics: the list of corrupted slaves (LCS, command 70),
    the slaves' error counters (71), the telegram counters (129); and the list of offline
    slaves (LOS). Reading clears the LCS and the counters, as on the master.

    Exit status: 0 shown, 1 the master lacks them (a gateway) or did not answer.

    \b
    Example:
      asictl diag
    """
    los = _list(set_los) if set_los is not None else None
    with open_master(**board) as master:
        tools = master.tools()
        if los is not None:
            check_overwrite(master, "set the list of offline slaves", real_master=real_master)
            tools.set_los(los)
        result = tools.diagnostics()
    if as_json:
        click.echo(json.dumps(asdict(result), indent=2))
        return
    errors = [f"{n}: {c}" for n, c in enumerate(result.error_counters) if c]
    click.echo(f"{master.name}: diagnostics (read and cleared)")
    click.echo("LCS      " + (", ".join(map(str, result.lcs)) or "(none)"))
    click.echo("errors   " + (", ".join(errors) or "(none)"))
    click.echo("LOS      " + (", ".join(map(str, result.los)) or "(none)"))
    click.echo(
        f"telegrams {result.telegrams} sent, {result.failed_telegrams} failed"
    )


# --------------------------------------------------------------------------- write


@click.command("write")
@click.argument("assignments", nargs=-1, required=True)
@board_options
@real_master_option
def write(
    assignments: tuple[str, ...], real_master: bool, **board: Unpack[BoardOptions]
) -> None:
    """Write flags and outputs: 'F 10.0=1' (a flag bit), 'FY 10=0x12' (a flag byte),
    'Q 17.3=1' (an output bit), 'Q 17=0b1000' (a slave's four outputs) or 'QB 16=0x5A'
    (slaves 16 and 17), or a name of the symbol table the program on the master carries
    ('Motor=1'). Values in decimal, 0x.., 0b.. or as IL writes them (12h). Outputs only
    while the control program is stopped: it owns them while it runs ('asictl force'
    holds them even then).

    Exit status: 0 written, 1 refused, 2 bad usage (nothing is written then).

    \b
    Examples:
      asictl write "F 10.0=1" "FY 11=0x12"
      asictl write "Q 17=0b1000"
    """
    with open_master(**board) as master:
        check_overwrite(master, "write flags and outputs", real_master=real_master)
        names = Names(master)
        flags, outputs = image_writes(
            [names.assignment(text, example="F 10.0=1") for text in assignments])
        tools = master.tools()
        if flags:
            write_flags(tools, flags)
        if outputs:
            tools.write_outputs(outputs)
    click.echo(f"{master.name}: wrote {', '.join(assignments)}", err=True)
    _lost_note(master, "flags and outputs are lost when it ends")
