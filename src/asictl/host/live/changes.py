"""What the clients of a live board changed on it, for the other clients' event logs.

A monitor polls the board several times a second and sees the state, but not who changed
it: a forced output, a download, a debugger that attached. The server notes each change
a client makes, in words and with the client's name as its session gave it (``asictl
force (pid 7)``), and any client asks for the changes after the last one it saw (the
``changes`` request, host.live.protocol). Reads are never noted, so a monitor's own
polling is never an event; a run of the same change by one client (the 69 blocks of a
download) is one.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING

from asictl.board.forcing import Area
from asictl.host.force_list import Entry, forced_values
from asictl.host.live.protocol import JSON
from asictl.observe.operands import image_symbols
from asictl.platform.master import ControlFlag
from asictl.platform.pc2 import (
    CONTROL_FLAGS,
    FLAGS,
    FLAGS_SIZE,
    HI_FLAGS,
    IMAGE_SIZE,
    ODI,
    READ_ONLY_COMMANDS,
    Command,
)

if TYPE_CHECKING:
    from asictl.board.board import Pc2Board

#: Changes kept for clients that ask late (a monitor asks every refresh).
KEPT = 200


@dataclass(frozen=True)
class Change:
    serial: int
    #: when, in seconds since the epoch
    at: float
    text: str
    #: the client that made it, as it named itself
    who: str

    def to_json(self) -> JSON:
        return [self.serial, self.at, self.text, self.who]

    @classmethod
    def from_json(cls, row: JSON) -> Change:
        serial, at, text, who = row
        return cls(int(serial), float(at), str(text), str(who))


class ChangeLog:
    """The latest ``KEPT`` changes, numbered from 1."""

    def __init__(self) -> None:
        self._kept: deque[Change] = deque(maxlen=KEPT)
        self.serial = 0

    def note(self, text: str, who: str) -> None:
        last = self._kept[-1] if self._kept else None
        if last is not None and (last.text, last.who) == (text, who):
            return
        self.serial += 1
        self._kept.append(Change(self.serial, time.time(), text, who))

    def since(self, serial: int) -> list[Change]:
        return [change for change in self._kept if change.serial > serial]


def command_change(board: Pc2Board, code: int) -> str | None:
    """A command the board acknowledged, in words; None for one that only reads."""
    if code in READ_ONLY_COMMANDS:
        return None
    if code == Command.DOWNLOAD:
        return "program downloaded"
    if code == Command.WRITE_CONTROL_FLAGS:
        flags = board.dpram_byte(CONTROL_FLAGS)
        if flags & ControlFlag.RESET:
            return "program reset"
        return "program started" if flags & ControlFlag.START else "program stopped"
    return f"command {code}{command_name(code)}"


def command_name(code: int) -> str:
    """`` (write control flags)`` for a code the PC2 knows, else nothing."""
    try:
        return f" ({Command(code).name.lower().replace('_', ' ')})"
    except ValueError:
        return ""


def write_change(address: int, value: int) -> str | None:
    """A host's write to the DPRAM that is data of its own (a flag byte, the outputs,
    the hi-flags), in words; None for the rest, which a command's change names."""
    if FLAGS <= address < FLAGS + FLAGS_SIZE:
        return f"FY {address - FLAGS}={value:#04x}"
    if ODI <= address < ODI + IMAGE_SIZE:
        return "outputs written"
    if address == HI_FLAGS:
        return f"hi-flags {value:02X}h"
    return None


def write_refused(address: int, value: int) -> str:
    """A host's write to the DPRAM, in words, for a refusal while the board is halted."""
    if address == CONTROL_FLAGS:
        return f"writing the AS-i Control flags ({CONTROL_FLAGS:03X}h: start, stop, reset)"
    return write_change(address, value) or f"writing DPRAM {address:03X}h"


def action_refused(board: Pc2Board, name: str, args: dict[str, JSON]) -> str:
    """An action, in words, for a refusal: before it ran, its arguments may not read."""
    try:
        return action_change(board, name, args)
    except (KeyError, TypeError, ValueError):
        return f"'{name}'"


def action_change(board: Pc2Board, name: str, args: dict[str, JSON]) -> str:
    """An emulated-board action that changed the board, in words, operands named by the
    program's symbol table: ``FORCE Q 3.1 (PumpB)=1``."""
    if name == "force":
        return "FORCE " + _operands(board, [(Area(str(a)), int(i), int(m), int(b))
                                            for a, i, m, b in args["changes"]])
    if name == "unforce":
        if args.get("all"):
            return "UNFORCE all"
        return "UNFORCE " + _operands(board, [(Area(str(a)), int(i), int(m), 0)
                                              for a, i, m in args["changes"]], values=False)
    if name == "inputs":
        return "INPUTS " + _operands(board, [(Area.INPUTS, int(a), int(m), int(b))
                                             for a, m, b in args["changes"]])
    if name in ("plug", "unplug"):
        return f"slave {int(args['address'])} {name}ged"
    return {"match": "cable matched to the projected configuration",
            "populate": "slaves of the program's [SETUP] plugged in",
            "set_button": "set button pressed"}.get(name, name)


def _operands(board: Pc2Board, entries: list[Entry], *, values: bool = True) -> str:
    symbols = image_symbols(board.loaded_image)
    return ", ".join(
        value.operand + (f" ({value.symbol})" if value.symbol else "")
        + (f"={value.value}" if values else "")
        for value in forced_values(entries, symbols)
    )
