"""``asictl gateway serve``: the emulated AS-i/Modbus gateway in front of a PC2 board.

The gateway serves the same persistent emulated board that ``download``/``upload``/``status
--port`` use, holding its lock while it runs, so a program downloaded over Modbus is the one
a PC2-port upload reads back afterwards (docs/modbus.md).
"""

from __future__ import annotations

import asyncio
import json
import signal
import time

import click

from asictl.cli.serial_options import serial_options, unit_option
from asictl.errors import UserError
from asictl.files import write_atomic
from asictl.host.boards import (
    emulated_board,
    lock_file,
    parse_port,
    state_directory,
    state_file,
)
from asictl.host.locking import note_holder
from asictl.host.target import check_serial_setting, port_number

#: The board's non-volatile state is written this often while serving (and at the end).
SAVE_INTERVAL_S = 10.0


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
        from asictl.gateway.server import ConditionLog, GatewayServer, SerialSettings
        from asictl.gateway.slave import GatewaySlave
    except ImportError as exc:
        raise UserError(
            f"the gateway needs pymodbus and pyserial ({exc}): pip install 'asictl[modbus]'"
        ) from None

    base = parse_port(port)
    directory = state_directory(state_dir)
    address = _tcp_address(tcp) if tcp else (None if rtu else ("127.0.0.1", 5020))
    check_serial_setting(int(baud), parity, int(stopbits))
    line = SerialSettings(rtu, int(baud), parity, int(stopbits)) if rtu else None
    with emulated_board(base, directory, wait=wait, notify=_notify) as board:
        slave = GatewaySlave(board, unit)
        if verbose:
            slave.request_log = _notify
        path = state_file(directory, base)
        saved = [time.monotonic()]
        failing = [False]
        conditions = ConditionLog(_notify)

        def save_now_and_then() -> None:
            if time.monotonic() - saved[0] < save_interval:
                return
            saved[0] = time.monotonic()
            try:
                write_atomic(path, json.dumps(board.nonvolatile(), indent=1, sort_keys=True)
                             + "\n")
            except UserError as exc:
                failing[0] = True
                conditions.event("save", f"gateway: cannot save the board state ({exc}); "
                                 f"trying again every {save_interval:g} s, still serving")
                return
            if failing[0]:
                failing[0] = False
                _notify(f"gateway: the board state is saved again in {path}")

        server = GatewayServer(
            slave, on_tick=save_now_and_then, max_connections=max_connections,
            idle_timeout=idle_timeout, log=_notify,
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
            note_holder(lock_file(directory, base), note)
            click.echo(
                f"asictl: gateway unit {unit} for board {port} serving "
                + ", ".join(where) + " (Ctrl-C stops)",
                err=True,
            )

        async def until_stopped() -> None:
            # Ctrl-C and a service manager's SIGTERM end the serving loop itself, so the
            # endpoints close and the state is saved. (Set here, not inherited: a process
            # started in the background by a shell inherits SIGINT as ignored.)
            loop = asyncio.get_running_loop()
            for number in (signal.SIGINT, signal.SIGTERM):
                loop.add_signal_handler(number, server.stop)
            await server.serve(address, line, started=started)

        try:
            asyncio.run(until_stopped())
        except OSError as exc:
            raise UserError(f"cannot serve: {exc.strerror or exc}") from None
        click.echo("asictl: gateway stopped", err=True)
