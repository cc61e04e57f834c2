"""``asictl gateway serve``: the emulated AS-i/Modbus gateway in front of a PC2 board.

The gateway is a live board (``asictl serve``, host/live.py) with Modbus in front: the board
runs in real time, and the other commands for its port reach it through the live board's
socket meanwhile, so a program downloaded over Modbus is the one a PC2-port upload reads
back, and ``asictl monitor --port`` watches what the Modbus client does (docs/modbus.md).
A port that ``asictl serve`` already serves is refused: stop that first.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable

import click

from asictl.errors import UserError
from asictl.host.boards import parse_port, state_directory
from asictl.host.live import LiveBoard, run_live, socket_path


def _tcp_address(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise UserError(f"--tcp '{text}': expected HOST:PORT, e.g. 127.0.0.1:5020")
    return host or "127.0.0.1", int(port)


@click.group()
def gateway() -> None:
    """The emulated AS-i/Modbus gateway VAG-MOD-KF-R4."""


@gateway.command("serve")
@click.option(
    "--tcp", "tcp", metavar="HOST:PORT",
    help="Serve Modbus/TCP here [default: 127.0.0.1:5020 unless --rtu is given].",
)
@click.option("--rtu", metavar="DEVICE", help="Serve Modbus RTU on this serial device.")
@click.option("--baud", type=int, default=9600, show_default=True)
@click.option("--parity", type=click.Choice(["N", "E", "O"]), default="N", show_default=True)
@click.option("--stopbits", type=click.Choice(["1", "2"]), default="1", show_default=True)
@click.option("--unit", type=click.IntRange(1, 247), default=1, show_default=True,
              help="The gateway's Modbus slave address (0 is broadcast).")
@click.option("--port", default="300h", show_default=True,
              help="The emulated PC2 board (by I/O base) the gateway serves.")
@click.option("--state-dir", type=click.Path(file_okay=False),
              help="Where emulated boards are kept (as for download/upload).")
def serve(
    tcp: str | None, rtu: str | None, baud: int, parity: str, stopbits: str, unit: int,
    port: str, state_dir: str | None,
) -> None:
    """Serve the board over Modbus until Ctrl-C; its state is saved periodically and at exit."""
    try:
        from asictl.gateway.server import GatewayServer, SerialSettings
        from asictl.gateway.slave import GatewaySlave
    except ImportError as exc:
        raise UserError(
            f"the gateway needs pymodbus and pyserial ({exc}): pip install 'asictl[modbus]'"
        ) from None

    base = parse_port(port)
    directory = state_directory(state_dir)
    address = _tcp_address(tcp) if tcp else (None if rtu else ("127.0.0.1", 5020))
    line = SerialSettings(rtu, baud, parity, int(stopbits)) if rtu else None

    def gateway_for(live: LiveBoard) -> tuple[Awaitable[None], Callable[[], None]]:
        server = GatewayServer(GatewaySlave(live.board, unit, sync=live.sync))

        def started() -> None:
            listening = server.tcp_address  # set before started() if it serves TCP
            where = [f"tcp {listening[0]}:{listening[1]}"] if listening is not None else []
            where += [f"rtu {rtu} {baud} {parity}{stopbits}"] if rtu else []
            click.echo(
                f"asictl: gateway unit {unit} for board {port} serving "
                + ", ".join(where) + f"; the board is live at {socket_path(directory, base)}"
                " (Ctrl-C stops)",
                err=True,
            )

        return server.serve(address, line, started=started), server.stop

    run_live(
        base, directory, identity={"command": "asictl gateway serve", "port": port},
        attach=gateway_for,
    )
    click.echo("asictl: gateway stopped", err=True)
