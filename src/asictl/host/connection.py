"""Reaching a master, whichever way: an emulated or real PC2 board, or a Modbus gateway.

The commands name a master by options (``--port``/``--io``/``--state-dir`` for a PC2
board, ``--modbus`` and its serial settings for a gateway); ``connect_master`` turns them
into a ``Master`` (host.master): a ``Pc2Master`` over the board's registers, with the
emulated-only capability for an emulated board, or a ``ModbusMaster``.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from asictl.errors import ExitCode, UserError, missing_extra
from asictl.host.boards import connect, port_name, state_directory, state_file
from asictl.host.driver import EmulatedPort, Pc2Driver
from asictl.host.emulated import LoadedBoard
from asictl.host.master import Master
from asictl.host.pc2_master import Pc2Master
from asictl.host.target import DEFAULT_RETRIES, DEFAULT_TIMEOUT_S, parse_target
from asictl.image.eeprom import ProgramImage


@dataclass(frozen=True)
class MasterAddress:
    """Which master a command means, as its options say."""

    port: str = "300h"
    io: str = "emulated"
    state_dir: str | Path | None = None
    modbus: str | None = None
    unit: int = 1
    baud: int = 9600
    parity: str = "N"
    stopbits: int = 1
    timeout: float = DEFAULT_TIMEOUT_S
    retries: int = DEFAULT_RETRIES
    #: wait for an emulated board another process holds, rather than stop
    wait: bool = False


class NotServed(UserError):
    """No live server keeps the emulated board running (``connect_master``'s
    ``live_only``): a view that must not show a board frozen in its state file."""

    exit_code = ExitCode.FAILED


def _who() -> str:
    return f"{' '.join(['asictl', *sys.argv[1:2]])} (pid {os.getpid()})"


def _stderr(text: str) -> None:
    print(f"asictl: {text}", file=sys.stderr, flush=True)


@contextmanager
def connect_master(
    address: MasterAddress, notify: Callable[[str], None] | None = None, *,
    live_only: bool = False,
) -> Iterator[Master]:
    """The PC2 board at ``address.port``, or the gateway at ``address.modbus``;
    ``notify`` hears why a command waits (for a board another process or client holds).

    An emulated board that a live server (``asictl serve``) keeps running is reached
    through its socket, for the whole command in one session; otherwise the board is
    loaded from its state file under its lock, and saved afterwards; with ``live_only``
    it is not (``NotServed``): a board loaded for a moment does not run, so a live view
    of it would show a program "running" that nothing runs.
    """
    if address.modbus is None:
        from asictl.host.live.client import LiveActions, LivePort, open_live
        from asictl.host.search import resolve_port

        directory = state_directory(address.state_dir)
        base = resolve_port(address.port, address.io, directory, notify or _stderr)
        name = port_name(base)
        if address.io == "emulated":
            client = open_live(directory, base)
            if client is not None:
                try:
                    def waiting(holder: str) -> None:
                        (notify or _stderr)(
                            f"waiting for live board {name}, in use by {holder}"
                        )

                    with client.session(_who(), waiting):
                        live_port = LivePort(client)
                        yield Pc2Master.over(
                            Pc2Driver(live_port), name, action=LiveActions(client)
                        )
                        live_port.flush()
                finally:
                    client.close()
                return
            if live_only:
                raise NotServed(f"board {name}: no live board serves it")
            created = not state_file(directory, base).exists()
        else:
            created = False
        with connect(
            name, address.io, address.state_dir, wait=address.wait, notify=notify
        ) as driver:
            port = driver.port
            yield Pc2Master.over(
                driver, name, created=created,
                action=LoadedBoard(port.board) if isinstance(port, EmulatedPort) else None,
            )
        return
    target = parse_target(
        address.modbus, baud=address.baud, parity=address.parity, stopbits=address.stopbits
    )
    try:
        from asictl.host import modbus as gateway
    except ImportError as exc:
        raise missing_extra("--modbus", "modbus", str(exc)) from None
    with gateway.open_modbus(
        target, address.unit, timeout=address.timeout, retries=address.retries
    ) as transport:
        yield gateway.ModbusMaster(transport)


def cable_setup_slaves(master: Master, image: ProgramImage) -> None:
    """An emulated board with nothing on its AS-i cable gets the slaves of the program's
    [SETUP], as a plant built for the program would have them (they stay in its state)."""
    if master.action is not None:
        slaves = [[s.address, s.io_code, s.id_code] for s in image.configuration.slaves()]
        master.emulated("populate", slaves=slaves)
