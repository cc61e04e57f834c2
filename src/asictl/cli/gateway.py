"""``asictl gateway serve|panel|press``: the emulated AS-i/Modbus gateway in front of a PC2
board, and its front panel.

The gateway is a live board (``asictl serve``, host/live/) with Modbus in front: the board
runs in real time, holding its lock, and the other commands for its port reach it through
the live board's socket meanwhile, so a program downloaded over Modbus is the one a PC2-port
upload reads back, and ``asictl monitor --port`` watches what the Modbus client does
(docs/modbus.md). A port that ``asictl serve`` already serves is refused: stop that first.
``panel`` and ``press`` reach the served gateway's front panel through the same socket.
"""

from __future__ import annotations

import json
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import click
from click.core import ParameterSource

from asictl.cli.opcua_options import opcua_attachment, opcua_options
from asictl.cli.options import Duration
from asictl.cli.serial_options import serial_options, unit_option
from asictl.cli.web_options import web_attachment, web_options
from asictl.diagnostics import printable
from asictl.errors import ExitCode, UserError, missing_extra
from asictl.host.emulated.boards import lock_file, state_directory
from asictl.host.emulated.locking import note_holder
from asictl.host.live.board import LiveBoard
from asictl.host.live.client import LiveClient, open_live, served_by
from asictl.host.live.protocol import socket_path
from asictl.host.live.saver import SAVE_INTERVAL_S
from asictl.host.live.server import run_live, together
from asictl.host.search import resolve_port
from asictl.host.transports.ports import port_name
from asictl.host.transports.target import check_serial_setting, port_number
from asictl.platform.display import Display, led_text
from asictl.platform.gateway import Interface


def _tcp_address(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    number = port_number(port)
    if not sep or number is None:
        shown = text if len(text) <= 40 else f"{text[:37]}..."
        raise UserError(f"--tcp '{shown}': expected HOST:PORT, e.g. 127.0.0.1:5020")
    return host or "127.0.0.1", number


def _notify(message: str) -> None:
    click.echo(f"asictl: {printable(message)}", err=True)


def _url_host(host: str) -> str:
    return f"[{host}]" if ":" in host else host


@click.group()
def gateway() -> None:
    """The emulated AS-i/Modbus gateway VAG-MOD-KF-R4.

    \b
    Examples:
      asictl gateway panel
      asictl gateway press set
    """


@gateway.command("serve")
@click.option(
    "--tcp", "tcp", metavar="HOST:PORT",
    help="Serve Modbus/TCP here [default: 127.0.0.1:5020 unless --rtu is given].",
)
@click.option("--rtu", metavar="DEVICE", help="Serve Modbus RTU on this serial device.")
@serial_options("--rtu")
@unit_option("The gateway's Modbus slave address, as set on the gateway (0 is broadcast).")
@click.option("--port", default="300h", show_default=True,
              help="The emulated PC2 board (by I/O base) the gateway serves; auto: the first "
              "one the state directory has (300h..32Ch).")
@click.option("--state-dir", type=click.Path(file_okay=False),
              help="Where emulated boards are kept (as for download/upload).")
@click.option("--wait", is_flag=True,
              help="If another process holds the board, wait for it instead of stopping.")
@click.option("-v", "--verbose", is_flag=True,
              help="Log every request on stderr: unit, function, address, quantity, outcome "
              "(answer, exception code, or why there is none).")
@click.option("--max-connections", type=click.IntRange(1, 1000), default=32, show_default=True,
              help="TCP connections served at once; further ones are closed at once.")
@click.option("--idle-timeout", type=Duration(), default="60s", show_default=True,
              metavar="TIME", help="Close a TCP connection silent this long (0: never).")
@click.option("--frame-timeout", type=Duration(least_ms=10), default="500ms",
              show_default=True, metavar="TIME",
              help="Close a TCP connection whose frame has not arrived whole this long after "
              "its first byte.")
@click.option("--save-interval", type=Duration(least_ms=100), default=f"{SAVE_INTERVAL_S:g}s",
              show_default=True, metavar="TIME",
              help="How often the board's state is saved while serving.")
@opcua_options
@web_options
def serve(
    tcp: str | None, rtu: str | None, baud: str, parity: str, stopbits: str, unit: int,
    port: str, state_dir: str | None, wait: bool, verbose: bool, max_connections: int,
    idle_timeout: float, frame_timeout: float, save_interval: float, opcua: str | None,
    opcua_writable: bool, opcua_user: str | None, opcua_interval: float, opcua_max_connections: int,
    opcua_max_sessions: int, opcua_login_timeout: float,
    opcua_symbols: str | None, http: str | None, http_writable: bool,
    http_download: bool, http_token_file: str | None, http_interval: float,
) -> None:
    """Serve the board over Modbus until Ctrl-C; its state is saved periodically and at exit.

    At most --max-connections TCP connections are served at once: a new one takes the
    place of the one silent longest, or is closed at once if all are in use. A state save
    that fails while serving (the state directory removed, the disk full) is logged and
    tried again at the next interval; serving goes on.

    The front panel works as on the gateway ('asictl gateway press', 'asictl gateway
    panel'): a Modbus address and serial setting stored by its keys (both keys held 5 s)
    are used from then on and by the next 'gateway serve' of this board, unless --unit,
    --baud, --parity or --stopbits say otherwise.

    With --opcua the same board is served over OPC UA too (docs/opcua.md), and with
    --http as a web page and REST API (docs/web.md), as the current AS-i gateways do.

    \b
    Examples:
      asictl gateway serve
      asictl gateway serve --rtu /dev/ttyUSB0 --baud 19200 --parity even --unit 2
      asictl gateway serve --tcp 127.0.0.1:1502 --opcua 127.0.0.1:4840
      asictl gateway serve --http 127.0.0.1:8080
    """
    try:
        from asictl.gateway.interface_file import interface_file, load_interface, save_interface
        from asictl.gateway.panel_actions import panel_actions
        from asictl.gateway.server import GatewayServer, SerialSettings
        from asictl.gateway.slave import GatewaySlave
    except ImportError as exc:
        raise missing_extra("the gateway", "modbus", str(exc)) from None

    directory = state_directory(state_dir)
    base = resolve_port(port, "emulated", directory, _notify)
    port = port_name(base)
    address = _tcp_address(tcp) if tcp else (None if rtu else ("127.0.0.1", 5020))
    stored_at = interface_file(directory, base)
    interface = _interface(
        load_interface(stored_at), stored_at, unit=unit, baud=int(baud), parity=parity,
        stopbits=int(stopbits),
    )
    check_serial_setting(interface.baud, interface.parity, interface.stopbits)
    line = (
        SerialSettings(rtu, interface.baud, interface.parity, interface.stopbits)
        if rtu else None
    )
    live_at = socket_path(directory, base)
    opcua_server = opcua_attachment(
        opcua, opcua_writable, opcua_user, opcua_interval / 1000, opcua_symbols, port, _notify,
        max_connections=opcua_max_connections, max_sessions=opcua_max_sessions,
        login_timeout=opcua_login_timeout / 1000,
    )
    page = web_attachment(
        http, http_writable, http_download, http_token_file, http_interval / 1000, port, _notify
    )

    def gateway_for(live: LiveBoard) -> tuple[Awaitable[None], Callable[[], None]]:
        slave = GatewaySlave(live.board, interface.unit, sync=live.sync, interface=interface)
        if verbose:
            slave.request_log = _notify
        server = GatewayServer(
            slave, max_connections=max_connections, idle_timeout=idle_timeout / 1000,
            frame_timeout=frame_timeout / 1000, on_request=live.save_changes, log=_notify,
        )
        live.actions.update(panel_actions(slave, lambda: server.tcp_address))

        def where() -> str:
            now = slave.panel.interface
            listening = server.tcp_address  # set before started() if it serves TCP
            places = [f"tcp {listening[0]}:{listening[1]}"] if listening is not None else []
            places += [f"rtu {rtu} {now.baud} {now.parity}{now.stopbits}"] if rtu else []
            return ", ".join(places)

        def note() -> None:
            unit_now = slave.panel.interface.unit
            text = f"it serves the board as Modbus gateway unit {unit_now} on {where()}"
            if server.tcp_address:
                host, tcp_port = server.tcp_address
                text += f": reach the board through it with --modbus tcp://{_url_host(host)}:"
                text += f"{tcp_port}" + (f" --unit {unit_now}" if unit_now != 1 else "")
            text += f"; the board is live at {live_at}"
            note_holder(lock_file(directory, base), text)

        def started() -> None:
            note()
            click.echo(
                f"asictl: gateway unit {interface.unit} for board {port} serving {where()}; "
                f"the board is live at {live_at} (Ctrl-C stops)",
                err=True,
            )

        def stored(now: Interface) -> None:
            save_interface(stored_at, now)
            server.set_serial(now.baud, now.parity, now.stopbits)
            note()
            _notify(
                f"gateway: the keys stored Modbus address {now.unit}, {now.baud} baud "
                f"{now.parity}{now.stopbits} (in {stored_at})"
            )

        slave.panel.on_interface.append(stored)
        return server.serve(address, line, started=started), server.stop

    run_live(
        base, directory,
        identity={"command": "asictl gateway serve", "port": port, "front_panel": True},
        attach=together(gateway_for, *(a for a in (opcua_server, page) if a is not None)),
        wait=wait, notify=_notify, save_interval=save_interval / 1000,
    )
    click.echo("asictl: gateway stopped", err=True)


def _interface(
    stored: Interface | None, stored_at: Path, *, unit: int, baud: int, parity: str,
    stopbits: int,
) -> Interface:
    """The options, where given; else what the gateway's keys stored, else the defaults."""
    given = Interface(unit, baud, parity, stopbits)
    if stored is None:
        return given
    ctx = click.get_current_context()

    def chosen(name: str) -> bool:
        return ctx.get_parameter_source(name) is not ParameterSource.DEFAULT

    now = Interface(
        unit if chosen("unit") else stored.unit,
        baud if chosen("baud") else stored.baud,
        parity if chosen("parity") else stored.parity,
        stopbits if chosen("stopbits") else stored.stopbits,
    )
    if now != given:
        _notify(
            f"gateway: Modbus address {now.unit}, {now.baud} baud {now.parity}{now.stopbits} "
            f"as its keys stored them ({stored_at}; the options override)"
        )
    return now


# --------------------------------------------------------------------------- the panel


def _served_gateway(port: str, state_dir: str | None) -> LiveClient:
    """The live socket of the gateway serving board ``port``; exit 1 if none does."""
    directory = state_directory(state_dir)
    base = resolve_port(port, "emulated", directory, _notify)
    name = port_name(base)
    client = open_live(directory, base)
    if client is None:
        raise UserError(
            f"no gateway serves board {name}: start one with 'asictl gateway serve --port "
            f"{name}'", ExitCode.FAILED,
        )
    if not client.server.get("front_panel"):
        who = served_by(client)
        client.close()
        raise UserError(
            f"board {name} is served by {who}, which has no front panel: the panel is the "
            "gateway's ('asictl gateway serve')", ExitCode.FAILED,
        )
    return client


def panel_text(view: dict[str, Any]) -> str:
    """The panel as lines: display, LEDs, keys, the settings menu."""
    display = Display.from_json(view["display"])
    held = view.get("held") or []
    keys = "locked (Modbus register 1007)" if view.get("keys_locked") else "free"
    if held:
        keys += f"; held: {' and '.join(held)}"
    lines = [
        f"display  {display.shown()}",
        f"leds     {led_text(view['leds'])}",
        f"keys     {keys}",
        f"modbus   unit {view['unit']}, {view['serial']}",
    ]
    if view.get("menu"):
        lines.append(
            "menu     interface settings: the " + (
                "Modbus address" if view["menu"] == "address" else "serial setting"
            ) + " (set: next, mode: store)"
        )
    return "\n".join(lines) + "\n"


_PANEL_OPTIONS = [
    click.option("--port", default="300h", show_default=True,
                 help="The board the gateway serves (by I/O base; auto: the first found)."),
    click.option("--state-dir", type=click.Path(file_okay=False),
                 help="Where emulated boards are kept (as for gateway serve)."),
    click.option("--json", "as_json", is_flag=True, help="The panel as one JSON object."),
]


def _panel_options(command: Callable[..., None]) -> Callable[..., None]:
    for option in reversed(_PANEL_OPTIONS):
        command = option(command)
    return command


@gateway.command("panel")
@_panel_options
def panel(port: str, state_dir: str | None, as_json: bool) -> None:
    """Show the served gateway's front panel: the display (and whether it blinks), the
    seven LEDs, the keys (locked by register 1007?) and its Modbus settings.

    Exit status: 0 shown, 1 no gateway serves the board, 2 bad usage.

    \b
    Examples:
      asictl gateway panel
      asictl gateway panel --port 300h
    """
    client = _served_gateway(port, state_dir)
    try:
        view = client.action("panel")
    finally:
        client.close()
    click.echo(json.dumps(view, indent=2) if as_json else panel_text(view), nl=as_json)


@gateway.command("press")
@click.argument("key", required=False, type=click.Choice(["mode", "set"]))
@click.option("--hold", type=Duration(least_ms=50, limit_ms=20_000), default="200ms",
              show_default=True, metavar="TIME",
              help="How long the key is held (5 s or more: a long press).")
@click.option("--both", is_flag=True, help="Press mode and set together.")
@_panel_options
def press(
    key: str | None, hold: float, both: bool, port: str, state_dir: str | None, as_json: bool,
) -> None:
    """Press the served gateway's mode or set key for the --hold time (both with --both),
    and show the panel when the keys are up again.

    A press of 5 s or more is long (gateway manual 5.2-5.6): mode held in protected mode
    enters configuration mode; in configuration mode a short mode press leaves it without
    storing, a long one stores the actual configuration first. set shows the next free
    (configuration mode) or wrongly configured (protected mode) address; held on it, the
    address blinks, and the next press gives the slave with address 0 that address; held
    on a detected slave, it deletes its address. Both keys held 5 s set the Modbus
    address and then the serial setting (set: next, mode: store). With the keys locked
    (register 1007) a press changes nothing and the display shows 82. docs/modbus.md
    lists every sequence.

    Exit status: 0 pressed, 1 no gateway serves the board, 2 bad usage.

    \b
    Examples:
      asictl gateway press mode --hold 5s  # protected -> configuration mode
      asictl gateway press mode            # configuration -> protected, not stored
    """
    if key is None and not both:
        raise UserError("which key? 'mode' or 'set' (or --both)", ExitCode.USAGE)
    keys = ["mode", "set"] if both else [key]
    client = _served_gateway(port, state_dir)
    try:
        view = client.action("press", keys=keys, hold_ms=hold)
    finally:
        client.close()
    click.echo(json.dumps(view, indent=2) if as_json else panel_text(view), nl=as_json)
