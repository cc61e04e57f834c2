"""The master as the commands see it, whichever way it is reached (docs/host.md).

``Master`` is all a command asks of a master: the functions a download, an upload, start
and stop are made of (``transport``), its state and status, the commissioning tools, and
the DPRAM where there is one. Two classes implement it: ``host.pc2_master.Pc2Master``
for a PC2 board through its three I/O registers, whichever way they are reached (a real
board through /dev/port, an emulated board loaded from its state file, a live board's
socket: the ``PortIO``\\ s of host.transports.driver and host.live.client), and
``host.modbus_master.ModbusMaster`` for an AS-i/Modbus gateway.

What only an emulated board can do (its AS-i cable, its set button, the program's timers,
counters and IL lines: host.emulated.actions) is a capability of its own,
``EmulatedBoard``, offered as ``Master.action`` and None on real hardware; a command that
needs it asks ``Master.emulated``, which refuses on real hardware with a message that says
why. ``host.connection.open_board`` is the one way to a ``Master``, and its ``with``
block is the connection's life: leaving it ends a live board's session, saves an emulated
board's state and releases its lock, or closes /dev/port or the Modbus connection.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

from asictl.errors import ExitCode, UserError

if TYPE_CHECKING:
    from asictl.host.commissioning import Commissioning
    from asictl.host.status import MasterStatus, StoredProgram
    from asictl.host.transfer import Transport
    from asictl.host.transports.driver import Pc2Driver

JSON = Any


class EmulatedBoard(Protocol):
    """The emulated-only capability: the actions of host.emulated.actions on the board,
    loaded here from its state file or served live."""

    @property
    def live(self) -> str | None:
        """Who keeps the board running live; None: it runs only while a command has it."""

    def run(self, name: str, args: dict[str, JSON]) -> JSON:
        """One action; after a change the board runs on a little, as it would meanwhile,
        so that the command's own report shows the effect."""

    def settle(self) -> None:
        """Let the board run on after a download, as a real one does meanwhile."""

    def wait_ms(self, ms: float) -> None:
        """Let ``ms`` of master time pass: a loaded board runs them at once, a live one in
        real time (a hardware reset's hold, an EMC test's reading interval)."""


class Master(Protocol):
    """A master as the commands see it, whichever way it is reached."""

    @property
    def name(self) -> str:
        """How the commands' messages name it: ``300h``, ``tcp://host:502 unit 1``."""

    @property
    def transport(self) -> Transport:
        """The master's functions: entry points, configuration, EEPROM, control flags."""

    @property
    def driver(self) -> Pc2Driver | None:
        """The DPRAM and the host commands of a PC2 board (None: a gateway has none)."""

    @property
    def action(self) -> EmulatedBoard | None:
        """What only an emulated board can do (None: real hardware)."""

    @property
    def quick_status(self) -> Callable[[StoredProgram], MasterStatus] | None:
        """The status with a program image the caller keeps instead of reading it again
        (a monitor's refresh); None: this master reports its program with its status."""

    @property
    def created(self) -> bool:
        """An emulated board that did not exist before this command (a new, empty one)."""

    def summary(self) -> str:
        """What the control program does, and why not, in one line."""

    def status(self) -> MasterStatus:
        """What ASI_MON's screens showed."""

    def tools(self) -> Commissioning:
        """ASI_MON's editor-mode functions on this master."""

    def emulated(self, name: str, **args: JSON) -> JSON:
        """Run an emulated-board action; on real hardware a clear refusal (exit 1)."""

    def settle(self) -> None:
        """Let an emulated board run on after a download; a real master runs by itself."""


def emulated_board(master: Master) -> EmulatedBoard:
    """The master's emulated-only capability, or the refusal a real master gets."""
    if master.action is None:
        raise UserError(
            f"{master.name} is not an emulated board: its AS-i cable cannot be changed "
            "from here", ExitCode.FAILED,
        )
    return master.action
