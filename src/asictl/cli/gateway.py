"""``asictl gateway serve``: the emulated AS-i/Modbus gateway in front of a PC2 board.

The gateway is a live board (``asictl serve``, host/live/) with Modbus in front: the board
runs in real time, holding its lock, and the other commands for its port reach it through
the live board's socket meanwhile, so a program downloaded over Modbus is the one a PC2-port
upload reads back, and ``asictl monitor --port`` watches what the Modbus client does
(docs/modbus.md). A port that ``asictl serve`` already serves is refused: stop that first.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable

import click

from asictl.cli.serial_options import serial_options, unit_option
from asictl.errors import UserError, missing_extra
from asictl.host.boards import lock_file, parse_port, state_directory
from asictl.host.live.board import LiveBoard
from asictl.host.live.protocol import socket_path
from asictl.host.live.saver import SAVE_INTERVAL_S
from asictl.host.live.server import run_live
from asictl.host.locking import note_holder
from asictl.host.target import check_serial_setting, port_number


def _tcp_address(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    number = port_number(port)
    if not sep or number is None:
        shown = text if len(text) <= 40 else f"{text[:37]}..."
        raise UserError(f"--tcp '{shown}': expected HOST:PORT, e.g. 127.0.0.1:5020")
    return host or "127.0.0.1", number


def _notify(message: str) -> None:
    click.echo(f"asictl: {message}", err=True)


def _url_host(host: str) -> str:
    return f"[{host}]" if ":" in host else host


@click.group()
def gateway() -> None:
    """The emulated AS-i/Modbus gateway VAG-MOD-KF-R4."""


@gateway.command("serve")
@click.option(
    "--tcp", "tcp", metavar="HOST:PORT",
    help="Serve Modbus/TCP here [default: 127.0.0.1:5020 unless --rtu is given].",
)
@click.option("--rtu", metavar="DEVICE", help="Serve Modbus RTU on this serial device.")
@serial_options("--rtu")
@unit_option("The gateway's Modbus slave address, as set on the gateway (0 is broadcast).")
@click.option("--port", default="300h", show_default=True,
              help="The emulated PC2 board (by I/O base) the gateway serves.")
@click.option("--state-dir", type=click.Path(file_okay=False),
              help="Where emulated boards are kept (as for download/upload).")
@click.option("--wait", is_flag=True,
              help="If another process holds the board, wait for it instead of stopping.")
@click.option("-v", "--verbose", is_flag=True,
              help="Log every request on stderr: unit, function, address, quantity, outcome "
              "(answer, exception code, or why there is none).")
@click.option("--max-connections", type=click.IntRange(1, 1000), default=32, show_default=True,
              help="TCP connections served at once; further ones are closed at once.")
@click.option("--idle-timeout", type=click.FloatRange(min=0), default=60.0, show_default=True,
              metavar="SECONDS", help="Close a TCP connection silent this long (0: never).")
@click.option("--save-interval", type=click.FloatRange(min=0.1), default=SAVE_INTERVAL_S,
              show_default=True, metavar="SECONDS",
              help="How often the board's state is saved while serving.")
def serve(
    tcp: str | None, rtu: str | None, baud: str, parity: str, stopbits: str, unit: int,
    port: str, state_dir: str | None, wait: bool, verbose: bool, max_connections: int,
    idle_timeout: float, save_interval: float,
) -> None:
    """Serve the board over Modbus until Ctrl-C; its state is saved periodically and at exit.

    At most --max-connections TCP connections are served at once: a new one takes the
    place of the one silent longest, or is closed at once if all are in use. A state save
    that fails while serving (the state directory removed, the disk full) is logged and
    tried again at the next interval; serving goes on.
    """
    try:
        from asictl.gateway.server import GatewayServer, SerialSettings
        from asictl.gateway.slave import GatewaySlave
    except ImportError as exc:
        raise missing_extra("the gateway", "modbus", str(exc)) from None

    base = parse_port(port)
    directory = state_directory(state_dir)
    address = _tcp_address(tcp) if tcp else (None if rtu else ("127.0.0.1", 5020))
    check_serial_setting(int(baud), parity, int(stopbits))
    line = SerialSettings(rtu, int(baud), parity, int(stopbits)) if rtu else None
    live_at = socket_path(directory, base)

    def gateway_for(live: LiveBoard) -> tuple[Awaitable[None], Callable[[], None]]:
        slave = GatewaySlave(live.board, unit, sync=live.sync)
        if verbose:
            slave.request_log = _notify
        server = GatewayServer(
            slave, max_connections=max_connections, idle_timeout=idle_timeout, log=_notify
        )

        def started() -> None:
            listening = server.tcp_address  # set before started() if it serves TCP
            where = [f"tcp {listening[0]}:{listening[1]}"] if listening is not None else []
            where += [f"rtu {rtu} {baud} {parity}{stopbits}"] if rtu else []
            note = f"it serves the board as Modbus gateway unit {unit} on {', '.join(where)}"
            if server.tcp_address:
                host, tcp_port = server.tcp_address
                note += f": reach the board through it with --modbus tcp://{_url_host(host)}:"
                note += f"{tcp_port}" + (f" --unit {unit}" if unit != 1 else "")
            note += f"; the board is live at {live_at}"
            note_holder(lock_file(directory, base), note)
            click.echo(
                f"asictl: gateway unit {unit} for board {port} serving "
                + ", ".join(where) + f"; the board is live at {live_at} (Ctrl-C stops)",
                err=True,
            )

        return server.serve(address, line, started=started), server.stop

    run_live(
        base, directory, identity={"command": "asictl gateway serve", "port": port},
        attach=gateway_for, wait=wait, notify=_notify, save_interval=save_interval,
    )
    click.echo("asictl: gateway stopped", err=True)
