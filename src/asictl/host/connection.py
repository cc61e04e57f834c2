"""Reaching a master, whichever way: an emulated or real PC2 board, or a Modbus gateway.

The commands name a master by options (``--port``/``--io``/``--state-dir`` for a PC2
board, ``--modbus`` and its serial settings for a gateway); ``connect_master`` turns them
into a ``Master``: the transport the download and upload procedures run on, and the
views a command reports with. What only an emulated board has (its AS-i cable) is
reachable through ``Master.board``.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from asictl.board.board import Pc2Board
from asictl.errors import ExitCode, UserError
from asictl.host.boards import connect, port_name, state_directory, state_file
from asictl.host.commissioning import Commissioning, ModbusCommissioning, Pc2Commissioning
from asictl.host.driver import EmulatedPort, Pc2Driver
from asictl.host.status import MasterStatus, StoredProgram, control_summary, read_status
from asictl.host.target import DEFAULT_RETRIES, DEFAULT_TIMEOUT_S, parse_target
from asictl.host.transfer import Pc2Transport, Transport
from asictl.image.eeprom import ProgramImage

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


#: An emulated-board action (``host.emulated``): its name and arguments, its result.
BoardAction = Callable[[str, dict[str, Any]], Any]


@dataclass(frozen=True)
class Master:
    """A master as the commands see it, whichever way it is reached."""

    transport: Transport
    name: str
    summary: Callable[[], str]
    status: Callable[[], MasterStatus]
    #: the emulated board behind the port, if it is loaded here from its state file
    board: Pc2Board | None = None
    #: the emulated-only actions (cable, set button, program view); None on real hardware
    action: BoardAction | None = None
    #: the PC2 driver, for a board reached through its I/O registers (not a gateway)
    driver: Pc2Driver | None = None
    #: who keeps the board running live, if a live board answered
    live: str | None = None
    #: an emulated board that did not exist before this command (a new, empty one)
    created: bool = False
    #: ASI_MON's editor-mode functions on this master
    commissioning: Commissioning | None = None
    #: the status with the program image given, not read again (a monitor)
    quick_status: Callable[[StoredProgram], MasterStatus] | None = None

    def tools(self) -> Commissioning:
        assert self.commissioning is not None, "every way to a master has them"
        return self.commissioning

    def emulated(self, name: str, **args: Any) -> Any:
        """Run an emulated-board action; on real hardware a clear refusal (exit 1)."""
        if self.action is None:
            raise UserError(
                f"{self.name} is not an emulated board: its AS-i cable cannot be changed "
                "from here", ExitCode.FAILED,
            )
        return self.action(name, args)


def _who() -> str:
    return f"{' '.join(['asictl', *sys.argv[1:2]])} (pid {os.getpid()})"


def _stderr(text: str) -> None:
    print(f"asictl: {text}", file=sys.stderr, flush=True)


def _pc2_master(
    driver: Pc2Driver, name: str, action: BoardAction | None = None, **extra: Any
) -> Master:
    def view() -> Any:
        return None if action is None else action("view", {})

    return Master(
        Pc2Transport(driver), name, lambda: control_summary(driver),
        lambda: read_status(driver, name, view), action=action, driver=driver,
        commissioning=Pc2Commissioning(driver, name),
        quick_status=lambda program: read_status(driver, name, view, program=program), **extra,
    )


@contextmanager
def connect_master(
    address: MasterAddress, notify: Callable[[str], None] | None = None
) -> Iterator[Master]:
    """The PC2 board at ``address.port``, or the gateway at ``address.modbus``;
    ``notify`` hears why a command waits (for a board another process or client holds).

    An emulated board that a live server (``asictl serve``) keeps running is reached
    through its socket, for the whole command in one session; otherwise the board is
    loaded from its state file under its lock, and saved afterwards.
    """
    if address.modbus is None:
        from asictl.host import live
        from asictl.host.search import resolve_port

        directory = state_directory(address.state_dir)
        base = resolve_port(address.port, address.io, directory, notify or _stderr)
        name = port_name(base)
        if address.io == "emulated":
            client = live.open_live(directory, base)
            if client is not None:
                try:
                    def waiting(holder: str) -> None:
                        (notify or _stderr)(
                            f"waiting for live board {name}, in use by {holder}"
                        )

                    with client.session(_who(), waiting):
                        live_port = live.LivePort(client)
                        yield _pc2_master(
                            Pc2Driver(live_port), name,
                            action=live.live_action(client, SETTLE_MS),
                            live=live.served_by(client),
                        )
                        live_port.flush()
                finally:
                    client.close()
                return
            created = not state_file(directory, base).exists()
        else:
            created = False
        with connect(
            name, address.io, address.state_dir, wait=address.wait, notify=notify
        ) as driver:
            port = driver.port
            board = port.board if isinstance(port, EmulatedPort) else None
            yield _pc2_master(
                driver, name, board=board, created=created,
                action=None if board is None else live.local_action(board, SETTLE_MS),
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
            commissioning=ModbusCommissioning(transport),
        )


def cable_setup_slaves(master: Master, image: ProgramImage) -> None:
    """An emulated board with nothing on its AS-i cable gets the slaves of the program's
    [SETUP], as a plant built for the program would have them (they stay in its state)."""
    if master.action is not None:
        slaves = [[s.address, s.io_code, s.id_code] for s in image.configuration.slaves()]
        master.emulated("populate", slaves=slaves)


def settle(master: Master) -> None:
    """Let an emulated board run on after a download, as a real one does meanwhile."""
    if master.board is not None:
        master.board.advance(SETTLE_MS)
    elif master.live is not None:
        time.sleep(SETTLE_MS / 1000)  # a live board runs on by itself
