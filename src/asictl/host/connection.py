"""Reaching a master, whichever way: an emulated or real PC2 board, or a Modbus gateway.

The commands name a master by options (``--port``/``--io``/``--state-dir`` for a PC2
board, ``--modbus`` and its serial settings for a gateway); ``connect_master`` turns them
into a ``Master``: the transport the download and upload procedures run on, and the
views a command reports with. What only an emulated board has (its AS-i cable) is
reachable through ``Master.board``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from asictl.board.asi import Slave
from asictl.board.board import Pc2Board
from asictl.errors import UserError
from asictl.host.boards import connect, parse_port, port_name
from asictl.host.driver import EmulatedPort
from asictl.host.status import MasterStatus, control_summary, read_status
from asictl.host.target import DEFAULT_RETRIES, DEFAULT_TIMEOUT_S, parse_target
from asictl.host.transfer import Pc2Transport, Transport
from asictl.image import ProgramImage

#: Master time an emulated board runs after a download: config_ok's delay after the
#: configuration was written, so the command's summary shows the program's state.
SETTLE_MS = 100.0


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


@dataclass(frozen=True)
class Master:
    """A master as the commands see it, whichever way it is reached."""

    transport: Transport
    name: str
    summary: Callable[[], str]
    status: Callable[[], MasterStatus]
    #: the emulated board behind the port, if it is one
    board: Pc2Board | None = None


@contextmanager
def connect_master(
    address: MasterAddress, notify: Callable[[str], None] | None = None
) -> Iterator[Master]:
    """The PC2 board at ``address.port``, or the gateway at ``address.modbus``;
    ``notify`` hears why a command waits (for a board another process holds)."""
    if address.modbus is None:
        with connect(
            address.port, address.io, address.state_dir, wait=address.wait, notify=notify
        ) as driver:
            name = port_name(parse_port(address.port))
            port = driver.port
            yield Master(
                Pc2Transport(driver), name, lambda: control_summary(driver),
                lambda: read_status(driver, name),
                port.board if isinstance(port, EmulatedPort) else None,
            )
        return
    target = parse_target(
        address.modbus, baud=address.baud, parity=address.parity, stopbits=address.stopbits
    )
    try:
        from asictl.host import modbus as gateway
    except ImportError as exc:
        raise UserError(
            f"--modbus needs pymodbus and pyserial ({exc}): pip install 'asictl[modbus]'"
        ) from None
    with gateway.open_modbus(
        target, address.unit, timeout=address.timeout, retries=address.retries
    ) as transport:
        yield Master(
            transport, f"{target} unit {address.unit}",
            lambda: gateway.control_summary(transport), lambda: gateway.read_status(transport),
        )


def cable_setup_slaves(master: Master, image: ProgramImage) -> None:
    """An emulated board with nothing on its AS-i cable gets the slaves of the program's
    [SETUP], as a plant built for the program would have them (they stay in its state)."""
    board = master.board
    if board is not None and not len(board.bus):
        for slave in image.configuration.slaves():
            board.bus.attach(Slave(slave.address, slave.io_code, slave.id_code))
        board.advance(SETTLE_MS)  # the master finds them


def settle(master: Master) -> None:
    """Let an emulated board run on after a download, as a real one does meanwhile."""
    if master.board is not None:
        master.board.advance(SETTLE_MS)
