"""What a scenario sees of the program besides its operands' values (which
``Simulation.read`` and ``view`` take from observe.view): when and why the program
stopped, with the IL line of a cycle time-out and the slaves of a configuration error,
and which firmware blocks refused (notes, not failures). ``Observation`` is the observer
(sim/observer.py) that notes them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from asictl.board.board import Pc2Board
from asictl.mcs51.emulator import Emulator
from asictl.observe.locate import current_line, describe
from asictl.platform import pc2 as d
from asictl.readers.units import format_instant
from asictl.runtime.firmware import FIRMWARE_BLOCKS
from asictl.runtime.line_map import LineMap
from asictl.sim.observer import Observer

if TYPE_CHECKING:  # the result holds the stops and refusals
    from asictl.sim.result import SimResult

#: Firmware blocks whose PSeg 0 reports success (00h) or a refusal (80h and up).
_STATUS_BLOCKS = frozenset({"setpp", "getpp", "sendprm", "getpi", "getpcd", "getcdi",
                            "dataex", "address", "autoaddr", "command"})


@dataclass
class Stop:
    at_ms: float
    reason: str
    #: the IL line, ``loop.asi:12`` (with its callers inside a block), when it is known
    where: str = ""

    @property
    def text(self) -> str:
        return f"{self.where}: {self.reason}" if self.where else self.reason

    @property
    def reported(self) -> str:
        """``at 55 ms: program stopped: loop.asi:9: cycle timeout``, as every tool says it."""
        return f"at {format_instant(self.at_ms)}: program stopped: {self.text}"


@dataclass
class Refusal:
    """A firmware block that answered with an error status (a note, not a failure)."""

    at_ms: float
    where: str
    block: str
    status: int
    count: int = 1
    last_ms: float = 0.0

    @property
    def text(self) -> str:
        more = (f" (and {self.count - 1} more time{'s' if self.count > 2 else ''} "
                f"until {format_instant(self.last_ms)})" if self.count > 1 else "")
        where = f"{self.where}: " if self.where else ""
        return f"{where}firmware block {self.block} refused (status {self.status:02X}h){more}"


class Observation(Observer):
    """The stops and the refusals of one run on ``board``; ``clock`` is master time
    since time 0 (0 before the first cycle)."""

    def __init__(
        self, board: Pc2Board, line_map: LineMap, clock: Callable[[], float], stops: list[Stop]
    ) -> None:
        self.board = board
        self.line_map = line_map
        self._clock = clock
        self.stops = stops
        self._refusals: dict[tuple[str, str, int], Refusal] = {}

    def finish(self, result: SimResult) -> None:
        result.refusals = self.refusals()

    def stopped(self, now: float) -> None:
        """The program stopped at ``now``: why, and where (a cycle time-out's IL line)."""
        board = self.board
        reason = board.stop_message or board.stop_reason.name
        where = ""
        runner = board.program
        if board.stop_reason is d.StopReason.CYCLE_TIMEOUT and runner is not None:
            cpu = runner.cpu
            stop = board.dpram[d.STOP_ADDRESS : d.STOP_ADDRESS + 2]  # the loop's jump
            line = self.line_map.line_at(int.from_bytes(stop, "little"))
            where = describe(line or current_line(cpu, self.line_map), cpu, self.line_map)
        elif board.stop_reason is d.StopReason.CONFIG_ERROR:
            problems = config_problems(board.dpram)
            if problems:
                reason += f" ({problems})"
        self.stops.append(Stop(now, reason, where))

    def loaded(self) -> None:
        """Note firmware blocks that refuse, at the IL line that called them."""
        runner = self.board.program
        if runner is None:
            return
        cpu = runner.cpu
        for name, address in runner.program.entry_points.items():
            original = cpu.traps.get(address)
            if original is None or name not in _STATUS_BLOCKS:
                continue
            cpu.add_trap(address, self._refusal_trap(name, original))

    def _refusal_trap(
        self, name: str, original: Callable[[Emulator], object]
    ) -> Callable[[Emulator], None]:
        block = name

        def trap(cpu: Emulator) -> None:
            pseg = cpu.dptr
            original(cpu)  # the firmware's work; it returns to the caller
            status = cpu.xdata.read(pseg)
            if status & 0x80:
                line = self.line_map.line_at(cpu.pc - 1)
                self._refused(block, status, describe(line, cpu, self.line_map) if line else "")

        return trap

    def _refused(self, block: str, status: int, where: str) -> None:
        now = self._clock()
        key = (where, block, status)
        found = self._refusals.get(key)
        if found is None:
            self._refusals[key] = Refusal(now, where, FIRMWARE_BLOCKS[block].name, status,
                                          last_ms=now)
        else:
            found.count += 1
            found.last_ms = now

    def refusals(self) -> list[Refusal]:
        return sorted(self._refusals.values(), key=lambda r: r.at_ms)


def config_problems(dpram: bytes) -> str:
    """Which slaves make the configuration wrong, from the master's lists (the host's view):
    ``slave 16 missing; slave 5 not projected; slave 3 is IO 7h ID 0h, projected IO Bh ID 0h``."""
    lps = d.slave_list(dpram[d.LPS : d.LPS + d.LIST_SIZE])
    lds = d.slave_list(dpram[d.LDS : d.LDS + d.LIST_SIZE])
    pcd, cdi = dpram[d.PCD : d.PCD + d.CONFIG_SIZE], dpram[d.CDI : d.CDI + d.CONFIG_SIZE]
    problems = [f"slave {n} missing" for n in sorted(lps - lds)]
    problems += [f"slave {n} not projected" for n in sorted(lds - lps) if n]
    problems += [
        f"slave {n} is IO {cdi[n] & 0xF:X}h ID {cdi[n] >> 4:X}h, projected IO "
        f"{pcd[n] & 0xF:X}h ID {pcd[n] >> 4:X}h"
        for n in sorted(lps & lds) if pcd[n] != cdi[n]
    ]
    return "; ".join(problems)
