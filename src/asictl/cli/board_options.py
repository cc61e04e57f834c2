"""The options that name a master, shared by every command that reaches one.

``--port``/``--io``/``--state-dir``/``--wait`` name a PC2 board, ``--modbus`` with
``--unit``, the serial settings, ``--timeout`` and ``--retries`` a gateway instead
(docs/host.md). ``board_options`` adds them to a command, ``master_address`` reads their
values into the ``MasterAddress`` the host side opens, and ``open_master`` opens it for
the command's ``with`` block, so every command says "open, act, close" the same way.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TypedDict, TypeVar, Unpack

import click
from click.core import ParameterSource

from asictl.cli.options import Duration, apply_options
from asictl.cli.serial_options import serial_options, unit_option
from asictl.diagnostics import printable
from asictl.errors import UserError
from asictl.host.connection import MasterAddress, open_board
from asictl.host.master import Master
from asictl.host.transports.ports import IO_BACKENDS
from asictl.host.transports.target import DEFAULT_RETRIES, DEFAULT_TIMEOUT_S

_Callback = TypeVar("_Callback", bound=Callable[..., object])


class BoardOptions(TypedDict):
    """The values of the options ``board_options`` adds, as click passes them."""

    port: str
    io: str
    state_dir: str | None
    wait: bool
    modbus: str | None
    unit: int
    baud: str
    parity: str
    stopbits: str
    timeout: float  # milliseconds, as --timeout reads it
    retries: int


def board_options(command: _Callback) -> _Callback:
    """Add the options that name a master to ``command`` (``BoardOptions``)."""
    options = [
        click.option(
            "--port", default="300h", show_default=True,
            help="The board's I/O base: 300h, 304h, 308h, 30Ch, 320h, 324h, 328h or 32Ch "
            "(also written 0x300 or 300); auto: search them in this order and take the first "
            "board found, as the PC2 driver's AsiPc2Init(0) does.",
        ),
        click.option(
            "--io", type=click.Choice(IO_BACKENDS), default="emulated", show_default=True,
            help="emulated: an emulated board kept in the state directory; devport: a real "
            "board through /dev/port (needs root).",
        ),
        click.option(
            "--state-dir", type=click.Path(file_okay=False),
            help="Where emulated boards are kept [default: $ASICTL_STATE_DIR, else "
            "$XDG_STATE_HOME/asictl or ~/.local/state/asictl].",
        ),
        click.option(
            "--wait", is_flag=True,
            help="If another process (such as 'asictl gateway serve') holds the emulated "
            "board, wait for it instead of stopping with exit status 1.",
        ),
        click.option(
            "--modbus", metavar="URL|DEVICE",
            help="Go through an AS-i/Modbus gateway instead of a PC2 board: tcp://HOST[:PORT] "
            "(Modbus TCP), rtu+tcp://HOST[:PORT] (RTU through a device server) or a serial "
            "device such as /dev/ttyUSB0 (RTU). Excludes --port, --io, --state-dir and --wait.",
        ),
        unit_option("The gateway's Modbus slave address (with --modbus)."),
        serial_options("Serial --modbus"),
        click.option(
            "--timeout", type=Duration(limit_ms=60_000, positive=True),
            default=f"{DEFAULT_TIMEOUT_S:g}s", show_default=True,
            help="--modbus: how long to wait for each answer (500ms, 2s).",
        ),
        click.option(
            "--retries", type=click.IntRange(0, 20), default=DEFAULT_RETRIES,
            show_default=True,
            help="--modbus: how often a request is repeated after a time-out or CRC error.",
        ),
    ]
    return apply_options(command, options)


#: The options that name a PC2 board, which --modbus excludes.
PC2_ONLY = ("port", "io", "state_dir", "wait")


def master_address(
    port: str, io: str, state_dir: str | None, wait: bool, modbus: str | None, unit: int,
    baud: str, parity: str, stopbits: str, timeout: float, retries: int,
) -> MasterAddress:
    """The master the board options name; --modbus excludes the PC2 board's options."""
    if modbus is not None:
        ctx = click.get_current_context()
        clash = [
            f"--{option.replace('_', '-')}" for option in PC2_ONLY
            if ctx.get_parameter_source(option) is not ParameterSource.DEFAULT
        ]
        if clash:
            raise UserError(f"--modbus and {', '.join(clash)} exclude each other")
    return MasterAddress(
        port, io, state_dir, modbus, unit, int(baud), parity, int(stopbits), timeout / 1000,
        retries, wait,
    )


@contextmanager
def open_master(**board: Unpack[BoardOptions]) -> Iterator[Master]:
    """The master the options name, for the command's ``with`` block. A board that did
    not exist yet is said so, whatever the command: a mistyped --state-dir or --port
    would otherwise go unnoticed."""
    with open_board(
        master_address(**board),
        notify=lambda message: click.echo(f"asictl: {printable(message)}", err=True),
    ) as master:
        if master.created:
            click.echo(
                f"asictl: note: there was no emulated board at {master.name} in the state "
                "directory: a new, empty one was created (is ASICTL_STATE_DIR or --state-dir "
                "the one you meant?)",
                err=True,
            )
        yield master


def master_wait(master: Master) -> Callable[[float], None]:
    """How a command lets master time pass: at once on a board loaded for the command,
    in real time on a live or real one."""
    if master.action is not None:
        return master.action.wait_ms
    return lambda ms: time.sleep(ms / 1000)
