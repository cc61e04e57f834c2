"""The status of a live board read in the process that serves it (the OPC UA server, the
web server): the master as ``asictl status`` reaches it, over the board's registers, with
the program image kept between readings as the monitor keeps it."""

from __future__ import annotations

from asictl.host.emulated.actions import LoadedBoard
from asictl.host.live.board import LiveBoard
from asictl.host.master import EmulatedBoard
from asictl.host.pc2_master import Pc2Master
from asictl.host.status import MasterStatus, StoredProgram, read_program
from asictl.host.transports.driver import EmulatedPort, Pc2Driver


class LiveStatus:
    """``read()`` the status now; the program is read again only when the board loaded
    another (reading it means an upload of the whole image)."""

    def __init__(self, live: LiveBoard, name: str, action: EmulatedBoard | None = None) -> None:
        self.live = live
        # master time through the live board, so a debugger's hold is kept to
        port = EmulatedPort(live.board, advance=live.advance, on_command=live.run_command)
        self.master = Pc2Master.over(
            Pc2Driver(port), name, action=action or LoadedBoard(live.board)
        )
        self.program: StoredProgram | None = None
        self._loaded: object = None

    def stored_program(self) -> StoredProgram:
        board = self.live.board
        if self.program is None or board.loaded_image is not self._loaded:
            self.program = read_program(self.master.transport)
            self._loaded = board.loaded_image
        return self.program

    def read(self) -> MasterStatus:
        program = self.stored_program()
        quick = self.master.quick_status
        assert quick is not None  # a PC2 master has one
        return quick(program)
