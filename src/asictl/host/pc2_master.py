"""``Master`` for a PC2 board, through its three I/O registers whichever way they are
reached: /dev/port (a real board), an emulated board loaded from its state file, or a
live board's socket. Below the ``PortIO`` line (host.transports.driver, host.live.client) the three
differ; above it one driver, one transport and one set of views serve them all, and an
emulated board adds its ``EmulatedBoard`` capability."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from asictl.host.emulated.actions import LoadedBoard
from asictl.host.master import JSON, EmulatedBoard, emulated_board
from asictl.host.status import MasterStatus, StoredProgram, View, control_summary, read_status
from asictl.host.transfer import Pc2Transport
from asictl.host.transports.driver import EmulatedPort, Pc2Driver

if TYPE_CHECKING:
    from asictl.board.board import Pc2Board
    from asictl.host.commissioning import Commissioning


@dataclass(frozen=True)
class Pc2Master:
    """A PC2 board as the commands see it (``Master``); made by ``over``."""

    name: str
    transport: Pc2Transport
    #: the driver ``transport`` runs on: the DPRAM and the host commands
    driver: Pc2Driver | None
    quick_status: Callable[[StoredProgram], MasterStatus] | None
    action: EmulatedBoard | None = None
    created: bool = False

    @classmethod
    def over(
        cls, driver: Pc2Driver, name: str, *, action: EmulatedBoard | None = None,
        created: bool = False,
    ) -> Pc2Master:
        view = _view(action)

        def quick_status(program: StoredProgram) -> MasterStatus:
            return read_status(driver, name, view, program=program)

        return cls(name, Pc2Transport(driver), driver, quick_status, action, created)

    @classmethod
    def loaded(cls, board: Pc2Board, name: str, *, created: bool = False) -> Pc2Master:
        """An emulated board this process holds (loaded from its state file, or served
        by it), reached through its registers as any other."""
        return cls.over(
            Pc2Driver(EmulatedPort(board)), name, action=LoadedBoard(board), created=created
        )

    def summary(self) -> str:
        return control_summary(self.transport.driver)

    def status(self) -> MasterStatus:
        return read_status(self.transport.driver, self.name, _view(self.action))

    def tools(self) -> Commissioning:
        from asictl.host.commissioning import Pc2Commissioning  # only commissioning needs it

        return Pc2Commissioning(self.transport.driver, self.name)

    def emulated(self, name: str, **args: JSON) -> JSON:
        return emulated_board(self).run(name, args)

    def settle(self) -> None:
        if self.action is not None:
            self.action.settle()


def _view(action: EmulatedBoard | None) -> Callable[[], View | None]:
    """What an emulated board shows beyond the DPRAM (LCS, error counters, timers)."""
    return lambda: None if action is None else action.run("view", {})
