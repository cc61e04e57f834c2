"""Opening a master, whichever way: an emulated or real PC2 board, or a Modbus gateway.

The commands name a master by options (``--port``/``--io``/``--state-dir`` for a PC2
board, ``--modbus`` and its serial settings for a gateway), read into a
``MasterAddress``; ``open_board`` is the one way from there to a ``Master``
(host.master), for a ``with`` block: every command opens, acts and closes. Which way it
goes is decided here, top-down, once:

- ``--modbus``: the gateway's transport (pymodbus), as a ``ModbusMaster``;
- ``--io devport``: a real board's three registers through /dev/port;
- an emulated board that a live server (``asictl serve``) keeps running: its socket,
  for the whole block in one session (host.live.client);
- any other emulated board: loaded from its state file under its lock, and saved when
  the block ends (host.emulated.boards, over host.emulated.state_files and host.emulated.locking).

Each PC2 way ends in a ``Pc2Master`` over the board's registers, with the emulated-only
capability where the board is emulated.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from asictl.errors import ExitCode, UserError, missing_extra
from asictl.host.emulated.boards import emulated_board, state_directory, state_file
from asictl.host.master import Master
from asictl.host.pc2_master import Pc2Master
from asictl.host.transports.driver import DevPort, Pc2Driver
from asictl.host.transports.ports import port_name
from asictl.host.transports.target import (
    DEFAULT_RETRIES,
    DEFAULT_TIMEOUT_S,
    ModbusTarget,
    parse_target,
)

if TYPE_CHECKING:
    from asictl.host.live.client import LiveClient
    from asictl.image.eeprom import ProgramImage

#: Hears why a command waits, or what it found (``--port auto``).
Notify = Callable[[str], None]


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
    """No live server keeps the emulated board running (``open_board``'s
    ``live_only``): a view that must not show a board frozen in its state file."""

    exit_code = ExitCode.FAILED


def client_name() -> str:
    """How this command names itself to a live board (``asictl force (pid 7)``): the
    board names it to other clients it keeps waiting or tells of its changes."""
    return f"{' '.join(['asictl', *sys.argv[1:2]])} (pid {os.getpid()})"


def _stderr(text: str) -> None:
    print(f"asictl: {text}", file=sys.stderr, flush=True)


@contextmanager
def open_board(
    address: MasterAddress, notify: Notify | None = None, *, live_only: bool = False,
) -> Iterator[Master]:
    """The master ``address`` names, for the ``with`` block; leaving it ends a live
    board's session, saves a loaded board and releases its lock, or closes /dev/port or
    the Modbus connection. ``notify`` hears why the command waits (for a board another
    process or client holds). With ``live_only`` an emulated board that no live server
    runs is refused (``NotServed``): a board loaded for a moment does not run, so a live
    view of it would show a program "running" that nothing runs.
    """
    way = (
        _gateway(address) if address.modbus is not None
        else _pc2_board(address, notify, live_only)
    )
    with way as master:
        yield master


def _pc2_board(
    address: MasterAddress, notify: Notify | None, live_only: bool,
) -> AbstractContextManager[Master]:
    """The PC2 board at ``address.port`` (``auto``: the first one found): real, live or
    loaded from its state file."""
    from asictl.host.live.client import open_live
    from asictl.host.search import resolve_port

    directory = state_directory(address.state_dir)
    base = resolve_port(address.port, address.io, directory, notify or _stderr)
    if address.io == "devport":
        return _real_board(base)
    client = open_live(directory, base)
    if client is not None:
        return _live_board(client, base, notify or _stderr)
    if live_only:
        raise NotServed(f"board {port_name(base)}: no live board serves it")
    return _loaded_board(base, directory, address.wait, notify)


@contextmanager
def _real_board(base: int) -> Iterator[Master]:
    """A real board's three registers through /dev/port."""
    device = DevPort(base)
    try:
        yield Pc2Master.over(Pc2Driver(device), port_name(base))
    finally:
        device.close()


@contextmanager
def _live_board(client: LiveClient, base: int, notify: Notify) -> Iterator[Master]:
    """The live board behind ``client``, in one session for the block (waiting, and
    saying so, while another client has it)."""
    from asictl.host.live.client import LiveActions, LivePort

    name = port_name(base)

    def waiting(holder: str) -> None:
        notify(f"waiting for live board {name}, in use by {holder}")

    try:
        with client.session(client_name(), waiting):
            port = LivePort(client)
            yield Pc2Master.over(Pc2Driver(port), name, action=LiveActions(client))
            port.flush()
    finally:
        client.close()


@contextmanager
def _loaded_board(
    base: int, directory: Path, wait: bool, notify: Notify | None,
) -> Iterator[Master]:
    """The emulated board at ``base`` loaded from its state file (a new one if it has
    none), under its lock, and saved when the block ends."""
    created = not state_file(directory, base).exists()
    with emulated_board(base, directory, wait=wait, notify=notify) as board:
        yield Pc2Master.loaded(board, port_name(base), created=created)


@contextmanager
def _gateway(address: MasterAddress) -> Iterator[Master]:
    """The gateway at ``address.modbus`` (pymodbus is loaded only here)."""
    assert address.modbus is not None
    target = parse_target(
        address.modbus, baud=address.baud, parity=address.parity, stopbits=address.stopbits
    )
    try:
        from asictl.host.modbus_master import ModbusMaster
        from asictl.host.transports.modbus import open_modbus
    except ImportError as exc:
        raise missing_extra("--modbus", "modbus", str(exc)) from None
    with open_modbus(
        target, address.unit, timeout=address.timeout, retries=address.retries
    ) as transport:
        yield ModbusMaster(transport, panel=_served_panel(address, target))


def _served_panel(
    address: MasterAddress, target: ModbusTarget
) -> Callable[[], dict[str, Any] | None] | None:
    """How to read the panel of the gateway at ``target``, if asictl may serve it here
    (Modbus TCP: ``asictl gateway serve --tcp``)."""
    host = target.host
    if host is None or target.rtu:
        return None
    from asictl.host.live.client import served_panel

    directory = state_directory(address.state_dir)

    def read() -> dict[str, Any] | None:
        view = served_panel(directory, host, target.port, address.unit)
        return view if isinstance(view, dict) else None

    return read


def cable_setup_slaves(master: Master, image: ProgramImage) -> None:
    """An emulated board with nothing on its AS-i cable gets the slaves of the program's
    [SETUP], as a plant built for the program would have them (they stay in its state)."""
    if master.action is not None:
        slaves = [[s.address, s.io_code, s.id_code] for s in image.configuration.slaves()]
        master.emulated("populate", slaves=slaves)
