"""``asictl serve`` and ``asictl bus``: a live emulated board, and the cable behind it.

``serve`` keeps an emulated board running in real time (host/live/) so that a program
runs between commands as on a real master, and every other command for that port reaches
it. ``bus`` is the emulated AS-i cable: which slaves are plugged in, their input data, and
``bus match`` to re-plug the cable to the downloaded program's [SETUP] (docs/commissioning.md).
"""

from __future__ import annotations

import json
from typing import Any, Unpack

import click
from click.core import ParameterSource

from asictl.cli.board_options import BoardOptions, board_options, open_master
from asictl.cli.opcua_options import opcua_attachment, opcua_options
from asictl.cli.options import Duration
from asictl.cli.web_options import web_attachment, web_options
from asictl.diagnostics import printable
from asictl.errors import ExitCode, UserError
from asictl.host.commissioning import image_changes
from asictl.host.emulated.actions import parse_address, parse_number, parse_profile
from asictl.host.emulated.boards import state_directory
from asictl.host.live.limits import (
    DEFAULT_ADMIT_WAIT_S,
    DEFAULT_IDLE_TIMEOUT_S,
    DEFAULT_MAX_CONNECTIONS,
    DEFAULT_SESSION_TIMEOUT_S,
)
from asictl.host.master import Master
from asictl.host.symbols import Names
from asictl.host.transports.ports import port_name
from asictl.il.ast import OperandKind as K


@click.command("serve")
@click.option(
    "--port", default="300h", show_default=True,
    help="The emulated board (by I/O base) to keep running; auto: the first one the "
    "state directory has (300h..32Ch).",
)
@click.option(
    "--state-dir", type=click.Path(file_okay=False),
    help="Where emulated boards are kept (as for download/upload).",
)
@click.option(
    "--wait", is_flag=True,
    help="If another process holds the board, wait for it instead of stopping.",
)
@click.option(
    "--max-connections", type=click.IntRange(1, 1000), default=DEFAULT_MAX_CONNECTIONS,
    show_default=True,
    help=f"Clients connected at once; further ones wait their turn (at most "
    f"{DEFAULT_ADMIT_WAIT_S:g} s, then: busy, try again).",
)
@click.option(
    "--session-timeout", type=Duration(), default=f"{DEFAULT_SESSION_TIMEOUT_S:g}s",
    show_default=True, metavar="TIME",
    help="End a command's hold on the board when it sends nothing this long (0: never).",
)
@click.option(
    "--idle-timeout", type=Duration(), default=f"{DEFAULT_IDLE_TIMEOUT_S:g}s",
    show_default=True, metavar="TIME",
    help="Close a connection that sends nothing this long (0: never).",
)
@opcua_options
@web_options
def serve(
    port: str, state_dir: str | None, wait: bool, max_connections: int,
    session_timeout: float, idle_timeout: float, opcua: str | None, opcua_writable: bool,
    opcua_user: str | None,
    opcua_interval: float, opcua_max_connections: int, opcua_max_sessions: int,
    opcua_login_timeout: float, opcua_symbols: str | None, http: str | None,
    http_writable: bool,
    http_download: bool, http_token_file: str | None, http_interval: float,
) -> None:
    """Keep the emulated board running in real time until Ctrl-C or SIGTERM.

    Master time follows the wall clock: the control program runs, its timers run, the
    slaves' inputs are read, whether or not a command is talking to the board. Every
    other asictl command for this port (download, status, bus, monitor, ...) reaches the
    running board through a socket in the state directory (owner-only) instead of its
    state file. A change of the board's non-volatile state (a download, store, setup,
    the cable) is saved before the command hears it is done; the rest every 10 s and at
    the end. 'asictl gateway serve' is the same live board with Modbus in front. A
    debugger attaches to the running program through a second socket ('asictl dap',
    attach). With --opcua an OPC UA server shows the master, its slaves, flags, timers
    and counters to HMI and SCADA clients (docs/opcua.md), read-only unless
    --opcua-writable. With --http a web page and REST API show the same (docs/web.md),
    read-only unless --http-writable.

    Exit status: 0 stopped by a signal, 1 the board is already served or held by another
    process (it is named; --wait waits for it), or its state could not be saved at the
    end (what is lost is said), 2 bad usage.

    \b
    Examples:
      asictl serve
      asictl serve --port 304h --opcua 127.0.0.1:4840
      asictl serve --http 127.0.0.1:8080
    """
    from asictl.debug.online import debug_socket_path, debugging
    from asictl.host.live.server import run_live, together
    from asictl.host.search import resolve_port

    def notify(text: str) -> None:
        click.echo(f"asictl: {printable(text)}", err=True)

    directory = state_directory(state_dir)
    base = resolve_port(port, "emulated", directory, notify)
    name = port_name(base)
    attach = debugging(debug_socket_path(directory, base))
    server = opcua_attachment(
        opcua, opcua_writable, opcua_user, opcua_interval / 1000, opcua_symbols, name, notify,
        max_connections=opcua_max_connections, max_sessions=opcua_max_sessions,
        login_timeout=opcua_login_timeout / 1000,
    )
    if server is not None:
        attach = together(attach, server)
    page = web_attachment(
        http, http_writable, http_download, http_token_file, http_interval / 1000, name, notify
    )
    if page is not None:
        attach = together(attach, page)

    def started(path: object) -> None:
        click.echo(f"asictl: board {name} live at {path} (Ctrl-C stops)", err=True)

    run_live(
        base, directory, identity={"command": "asictl serve", "port": name},
        started=started, wait=wait, notify=notify, max_connections=max_connections,
        session_timeout=session_timeout / 1000, idle_timeout=idle_timeout / 1000,
        attach=attach,
    )
    click.echo(f"asictl: board {name} stopped; its state is saved", err=True)


# --------------------------------------------------------------------------- bus


def _emulated_only(board: BoardOptions) -> None:
    _inherit_group_options(board)
    if board["modbus"] is not None or board["io"] != "emulated":
        raise UserError(
            "'asictl bus' works on emulated boards only: a real master's AS-i cable is "
            "changed by hand", ExitCode.USAGE,
        )


def _inherit_group_options(board: BoardOptions) -> None:
    """Board options given before the subcommand (``asictl bus --port 328h inputs ...``)
    count where the subcommand's own were left at their defaults: both places take them,
    and the group's used to be dropped, so the subcommand acted on board 300h."""
    ctx = click.get_current_context()
    group = ctx.parent
    if group is None or group.command is not bus:
        return
    for name in board:
        if (
            ctx.get_parameter_source(name) is ParameterSource.DEFAULT
            and group.get_parameter_source(name) not in (None, ParameterSource.DEFAULT)
        ):
            board[name] = group.params[name]  # type: ignore[literal-required]


def _report(master: Master) -> None:
    """The master's state after a change of the cable, and the fix for a config error."""
    click.echo(f"{master.name}: {master.summary()}", err=True)


@click.group("bus", invoke_without_command=True)
@board_options
@click.option("--json", "as_json", is_flag=True, help="Without a subcommand: JSON on stdout.")
@click.pass_context
def bus(ctx: click.Context, as_json: bool, **board: Unpack[BoardOptions]) -> None:
    """The emulated AS-i cable: its slaves, their inputs, plugging and unplugging.

    Without a subcommand: 'asictl bus show' (with the options given here). Emulated
    boards only.

    \b
    Examples:
      asictl bus
      asictl bus plug 5 iiio,1
    """
    if ctx.invoked_subcommand is None:
        ctx.invoke(show, as_json=as_json, **board)


def _slave_rows(slaves: list[dict[str, Any]]) -> str:
    if not slaves:
        return "  (no slaves plugged in)\n"
    lines = ["  addr  profile  IO  ID  inputs  outputs  param"]
    for s in slaves:
        lines.append(
            f"  {s['address']:>4}  {s['profile']:<7}  {s['io_code']:X}h  {s['id_code']:X}h  "
            f"{s['inputs']:04b}    {s['outputs']:04b}     {s['parameter']:X}h"
            + (f"  {s['name']}" if s.get("name") else "")
        )
    return "\n".join(lines) + "\n"


@bus.command("show")
@board_options
@click.option("--json", "as_json", is_flag=True, help="One JSON object on stdout.")
def show(as_json: bool = False, **board: Unpack[BoardOptions]) -> None:
    """The slaves on the cable: address, profile (I/O and ID code), inputs, outputs.

    \b
    Examples:
      asictl bus plug 5 iiio,1
      asictl bus show --json
    """
    _emulated_only(board)
    with open_master(**board) as master:
        cable = master.emulated("bus")
    if as_json:
        click.echo(json.dumps(cable, indent=2))
        return
    power = "on" if cable["powered"] else "OFF (AS-i power fail)"
    click.echo(f"{master.name}: AS-i cable, power {power}")
    click.echo(_slave_rows(cable["slaves"]), nl=False)


@bus.command("plug")
@click.argument("address")
@click.argument("profile")
@click.option(
    "--address-fault", type=click.Choice(["delete", "set", "store"]),
    help="A slave whose address programming fails: 'delete', it cannot be set to address "
    "0 and keeps its address (status 05h, STATUS 83A4h, the gateway's display 92); 'set', "
    "the new address does not take (06h, display 92); 'store', it is kept only until a "
    "power-up (07h, display 93).",
)
@board_options
def plug(
    address: str, profile: str, address_fault: str | None, **board: Unpack[BoardOptions]
) -> None:
    """Plug a slave in at ADDRESS (0 for a new slave) with PROFILE: its I/O code (letters
    such as iiio, or a hex digit) and ID code, as in [SETUP]: 'iiio,1', 'Bh,0'.

    \b
    Examples:
      asictl bus plug 5 iiio,1
      asictl bus plug 0 Bh,0 --address-fault set
    """
    _emulated_only(board)
    where = parse_address(address)
    io_code, id_code = parse_profile(profile)
    fault = {"address_fault": address_fault} if address_fault else {}
    with open_master(**board) as master:
        slave = master.emulated(
            "plug", address=where, io_code=io_code, id_code=id_code, **fault
        )
        click.echo(f"{master.name}: plugged in slave {where} ({slave['profile']})", err=True)
        _report(master)


@bus.command("unplug")
@click.argument("address")
@board_options
def unplug(address: str, **board: Unpack[BoardOptions]) -> None:
    """Unplug the slave at ADDRESS.

    \b
    Examples:
      asictl bus plug 5 iiio,1
      asictl bus unplug 5
    """
    _emulated_only(board)
    where = parse_address(address)
    with open_master(**board) as master:
        master.emulated("unplug", address=where)
        click.echo(f"{master.name}: unplugged slave {where}", err=True)
        _report(master)


@bus.command("match")
@board_options
def match(**board: Unpack[BoardOptions]) -> None:
    """Re-plug the cable to the [SETUP] of the program the master has loaded: slaves
    that fit stay (with their inputs), others go, missing ones are plugged in.

    \b
    Examples:
      asictl download demos/blink.asi
      asictl bus match
    """
    _emulated_only(board)
    with open_master(**board) as master:
        change = master.emulated("match")
        done = [f"plugged in {s['address']} ({s['profile']})" for s in change["plugged"]]
        done += [f"unplugged {s['address']} ({s['profile']})" for s in change["unplugged"]]
        click.echo(
            f"{master.name}: the cable matches the [SETUP]"
            + (": " + ", ".join(done) if done else " already"),
            err=True,
        )
        _report(master)


@bus.command("inputs")
@click.argument("settings", nargs=-1, required=True)
@board_options
def inputs(settings: tuple[str, ...], **board: Unpack[BoardOptions]) -> None:
    """Set the input data slaves deliver: 'ADDRESS VALUE' (VALUE 0b1011, 0xB, Bh or 11),
    or OPERAND=VALUE: input bits such as 'I 4.0=1', a slave's four inputs 'I 4=0b1011',
    two slaves' 'IB 4=0x5A', or a name of the program's symbol table ('Start=1');
    several at once are applied together.

    \b
    Examples:
      asictl bus plug 4 iiii,0
      asictl bus inputs "I 4.0=1"
      asictl bus inputs 4 0b0110
    """
    _emulated_only(board)
    changes: list[list[int]] = []
    pairs = len(settings) == 2 and "=" not in settings[0] + settings[1]
    if pairs:
        changes.append(
            [parse_address(settings[0]), 0xF, parse_number(settings[1], "input value", 15)]
        )
    with open_master(**board) as master:
        names = Names(master)
        for text in () if pairs else settings:
            assignment = names.assignment(text, example="I 4.0=1")
            if assignment.operand.node.kind not in (K.I, K.IB):
                raise UserError(f"'{assignment.written}' is no input: bus inputs sets what "
                                "slaves deliver (I, IB)", ExitCode.USAGE)
            changes += [list(change) for change in image_changes(assignment)]
        now = master.emulated("inputs", changes=changes)
        shown = ", ".join(f"slave {a} inputs {v:04b}" for a, v in now.items())
        click.echo(f"{master.name}: {shown}", err=True)
