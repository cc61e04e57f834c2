"""What only an emulated board can do or show: its AS-i cable, its set button, and the
program's timers and counters (which a real PC2 keeps in memory the host cannot see).

Each operation is a named *action* on a ``Pc2Board`` with JSON arguments and a JSON
result, so the same code serves a board loaded from its state file and a live board
behind its socket (``host.live``): the commands send the action's name and arguments,
whichever board they reach. Arguments come from the command line's parsers below, which
check them first; an action still refuses anything that does not fit the cable as it is
(``BusError``: a slave already at an address, no slave there).

``force``, ``unforce`` and ``forced`` are the force list (board/forcing.py), which only
an emulated board has: the PC2 firmware does not force.

``lines`` is the monitor's program view: each IL line with the register and operand
values of the latest program cycle, recorded on the board for that one cycle
(``observe.online``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from asictl.board.asi import BusError, Slave
from asictl.board.forcing import Area, ForceError, Forces
from asictl.errors import ExitCode, UserError
from asictl.observe.operands import read_number
from asictl.platform.master import IO_CODE_BITS, SLAVES, TICK_MS
from asictl.readers.profile import read_profile

if TYPE_CHECKING:
    # The board (and its 8051 emulator) is named only: the commands' parsers and the
    # live board's client use this module without loading it.
    from asictl.board.board import Pc2Board

JSON = Any
Action = Callable[["Pc2Board", dict[str, JSON]], JSON]

#: Master time an emulated board runs after a download or a change of its cable:
#: config_ok's delay after the configuration was written, so the command's report shows
#: the program's state.
SETTLE_MS = 100.0

class ActionError(UserError):
    """An emulated-board action that does not fit the board as it is (exit 1)."""

    exit_code = ExitCode.FAILED


# --------------------------------------------------------------------------- parsing


def parse_number(text: str, what: str, limit: int) -> int:
    """``0b1011``, ``0xB``, ``Bh`` or ``11`` (``observe.operands.read_number``): a value
    0..limit (exit 2 otherwise)."""
    try:
        value = read_number(text)
    except ValueError:
        raise UserError(
            f"{what} '{text}': expected a number such as 11, 0xB, Bh or 0b1011",
            ExitCode.USAGE,
        ) from None
    if not 0 <= value <= limit:
        raise UserError(f"{what} '{text}': must be 0..{limit}", ExitCode.USAGE)
    return value


def parse_address(text: str, *, zero: bool = True) -> int:
    """A slave address 1..31 (0 too where a new slave is meant)."""
    value = parse_number(text, "slave address", SLAVES - 1)
    if value == 0 and not zero:
        raise UserError(f"slave address '{text}': must be 1..31", ExitCode.USAGE)
    return value


def parse_profile(text: str) -> tuple[int, int]:
    """``iiio,1`` / ``Bh,0`` / ``7,F``: I/O code and ID code (default F), as
    ``readers.profile`` reads them (exit 2 for anything else)."""
    try:
        profile = read_profile(text)
    except ValueError as exc:
        raise UserError(f"profile {exc}", ExitCode.USAGE) from None
    if profile.parameter is not None:
        raise UserError(f"profile '{text}': a slave is plugged in with an I/O code and an "
                        "ID code", ExitCode.USAGE)
    return profile.io_code, profile.id_code


# --------------------------------------------------------------------------- actions


def _slave_json(slave: Slave) -> dict[str, JSON]:
    return {
        "address": slave.address, "io_code": slave.io_code, "id_code": slave.id_code,
        "profile": f"{IO_CODE_BITS[slave.io_code]},{slave.id_code:X}",
        "inputs": slave.inputs, "outputs": slave.outputs, "parameter": slave.parameter,
        "name": slave.name, "address_fault": slave.address_fault,
    }


def _bus(board: Pc2Board, args: dict[str, JSON]) -> JSON:
    return {
        "powered": board.bus.powered,
        "slaves": [_slave_json(s) for s in sorted(board.bus, key=lambda s: s.address)],
    }


def _plug(board: Pc2Board, args: dict[str, JSON]) -> JSON:
    address = int(args["address"])
    if board.bus.at(address):
        raise ActionError(f"a slave is already plugged in at address {address}; unplug it first")
    slave = Slave(
        address, int(args["io_code"]), int(args["id_code"]), int(args.get("inputs", 0)),
        address_fault=str(args.get("address_fault", "")),
    )
    board.bus.attach(slave)
    return _slave_json(slave)


def _unplug(board: Pc2Board, args: dict[str, JSON]) -> JSON:
    address = int(args["address"])
    found = board.bus.at(address)
    if not found:
        raise ActionError(f"no slave is plugged in at address {address}")
    for slave in found:
        board.bus.remove(slave)
    return [_slave_json(s) for s in found]


def _inputs(board: Pc2Board, args: dict[str, JSON]) -> JSON:
    """``changes``: [address, mask, bits]: the slave's input bits under ``mask`` become
    ``bits``; all are checked before any is applied."""
    changes = [(int(a), int(m), int(b)) for a, m, b in args["changes"]]
    slaves = []
    for address, _, _ in changes:
        found = board.bus.at(address)
        if len(found) != 1:
            raise ActionError(
                f"no slave is plugged in at address {address}" if not found
                else f"{len(found)} slaves answer at address {address}"
            )
        slaves.append(found[0])
    for slave, (_, mask, bits) in zip(slaves, changes, strict=True):
        slave.inputs = slave.inputs & ~mask & 0xF | bits & mask
    return {str(s.address): s.inputs for s in slaves}


def _configured(board: Pc2Board) -> list[tuple[int, int, int]]:
    image = board.loaded_image
    if image is None:
        raise ActionError(
            "the master has no program loaded whose [SETUP] the cable could match "
            "(download one first)"
        )
    return [(s.address, s.io_code, s.id_code) for s in image.configuration.slaves()]


def _replug(board: Pc2Board, wanted: list[tuple[int, int, int]]) -> JSON:
    """Make the cable hold exactly ``wanted``; slaves already right keep their inputs."""
    keep: list[Slave] = []
    unplugged: list[JSON] = []
    plugged: list[JSON] = []
    wanted_at = {a: (io, ident) for a, io, ident in wanted}
    for slave in board.bus:
        if wanted_at.get(slave.address) == (slave.io_code, slave.id_code) and not any(
            k.address == slave.address for k in keep
        ):
            keep.append(slave)
        else:
            board.bus.remove(slave)
            unplugged.append(_slave_json(slave))
    kept = {s.address for s in keep}
    for address, io_code, id_code in wanted:
        if address not in kept:
            plugged.append(_slave_json(board.bus.attach(Slave(address, io_code, id_code))))
    return {"plugged": plugged, "unplugged": unplugged, "kept": sorted(kept)}


def _match(board: Pc2Board, args: dict[str, JSON]) -> JSON:
    return _replug(board, _configured(board))


def _populate(board: Pc2Board, args: dict[str, JSON]) -> JSON:
    """An empty cable gets ``slaves`` (a download's [SETUP]); a cable with slaves stays."""
    if len(board.bus):
        return {"plugged": [], "unplugged": [], "kept": [s.address for s in board.bus]}
    return _replug(board, [(int(a), int(io), int(i)) for a, io, i in args["slaves"]])


def _set_button(board: Pc2Board, args: dict[str, JSON]) -> JSON:
    board.press_set_button()
    return None


def _view(board: Pc2Board, args: dict[str, JSON]) -> JSON:
    """What a monitor shows beyond the DPRAM: LCS and error counters (not cleared), the
    program's timers (remaining time, running) and counters."""
    lcs, counters = board.diagnostics()
    view: dict[str, JSON] = {
        "lcs": [a for a in range(SLAVES) if lcs >> a & 1],
        "error_counters": list(counters),
        "timers": [],
        "counters": [],
        "master_ms": board.now_ms,
        "bus_powered": board.bus.powered,
        "forced": _forced(board, {}),
    }
    runner = board.program
    if runner is not None:
        xdata = runner.cpu.xdata

        def word(address: int) -> int:
            return xdata.read(address) | xdata.read(address + 1) << 8

        view["timers"] = [
            {"number": n, "remaining_ms": word(a) * TICK_MS, "running": word(a) != 0}
            for n, a in sorted(runner.pmap.timers.items())
        ]
        view["counters"] = [
            {"number": n, "value": word(a)} for n, a in sorted(runner.pmap.counters.items())
        ]
    return view


def _forced(board: Pc2Board, args: dict[str, JSON]) -> JSON:
    """The force list: [area, index, mask, bits] per forced slave or flag byte."""
    return [[area.value, index, mask, bits] for area, index, mask, bits in board.forces.entries()]


def _force(board: Pc2Board, args: dict[str, JSON]) -> JSON:
    """``changes``: [area, index, mask, bits]: hold the bits under the mask; all are
    checked before any is forced."""
    changes = [(Area(str(a)), int(i), int(m), int(b)) for a, i, m, b in args["changes"]]
    trial = Forces()  # a force fails only its own checks, whatever is forced already
    for area, index, mask, bits in changes:
        trial.force(area, index, mask, bits)  # ForceError: out of range
    for area, index, mask, bits in changes:
        board.force(area, index, mask, bits)
    return _forced(board, {})


def _unforce(board: Pc2Board, args: dict[str, JSON]) -> JSON:
    """``changes``: [area, index, mask] to release, or ``all``: true; the list left and
    how many forces were released."""
    if args.get("all"):
        released = board.release()
    else:
        changes = [(Area(str(a)), int(i), int(m)) for a, i, m in args["changes"]]
        released = sum(board.release(area, index, mask) for area, index, mask in changes)
    return {"released": released, "forced": _forced(board, {})}


def _lines(board: Pc2Board, args: dict[str, JSON]) -> JSON:
    """The program's IL lines with their values in the latest cycle (observe.online)."""
    from asictl.observe.online import latest_cycle

    return latest_cycle(board)


ACTIONS: dict[str, Action] = {
    "bus": _bus,
    "plug": _plug,
    "unplug": _unplug,
    "inputs": _inputs,
    "match": _match,
    "populate": _populate,
    "set_button": _set_button,
    "view": _view,
    "lines": _lines,
    "force": _force,
    "unforce": _unforce,
    "forced": _forced,
}
#: Actions that only look: a command running them need not save the board's state.
VIEWS = frozenset({"bus", "view", "lines", "forced"})
#: Changes the running program sees in its next cycle, whose answer is all the command
#: reports (the slaves' inputs, the force list): unlike a change of the cable, they need
#: no time to settle before a report on a board that runs on by itself (a live one).
NEXT_CYCLE = frozenset({"inputs", "force", "unforce"})


def run_action(board: Pc2Board, name: str, args: dict[str, JSON]) -> JSON:
    """Run one action; a malformed request (only a buggy client sends one) is a BusError."""
    action = ACTIONS.get(name)
    if action is None:
        raise ActionError(f"the emulated board has no action '{name}'")
    try:
        return action(board, args)
    except (BusError, ForceError) as exc:
        raise ActionError(str(exc)) from None
    except (KeyError, TypeError, ValueError) as exc:
        raise ActionError(f"malformed '{name}' request: {exc}") from None


@dataclass(frozen=True)
class LoadedBoard:
    """``EmulatedBoard`` for a board loaded from its state file for one command: it runs
    only while the command has it, so after a change it runs on ``SETTLE_MS`` of master
    time, as it would meanwhile."""

    board: Pc2Board

    @property
    def live(self) -> None:
        return None

    def run(self, name: str, args: dict[str, JSON]) -> JSON:
        result = run_action(self.board, name, args)
        if name not in VIEWS:
            self.board.advance(SETTLE_MS)
        return result

    def settle(self) -> None:
        self.board.advance(SETTLE_MS)

    def wait_ms(self, ms: float) -> None:
        self.board.advance(ms)
