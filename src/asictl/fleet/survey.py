"""One piece of work on every master of a fleet at once, each on its own.

The masters are reached as the single-master commands reach them (host.connection's
``open_board``), a bounded number at a time in threads: a master's work is mostly
waiting for its answers (a Modbus round trip, a live board's socket), so a few threads
keep many masters busy. Each master has its own time-out and retries per request (its
``MasterAddress``), its own number of attempts at the whole work, and its own limit on
the time of the whole work, every attempt together (``FleetMaster.limit``: a gateway
that drips its answers fails within it). What goes wrong on one master (no answer, a
refusal, a corrupt image, a board another process holds, its limit) is that master's
outcome and never stops the others. Anything else is a bug and propagates.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass
from typing import Generic, TypeVar

from asictl.errors import UserError
from asictl.fleet.inventory import FleetMaster
from asictl.host.connection import open_board
from asictl.host.emulated.boards import state_directory, state_file
from asictl.host.master import Master
from asictl.host.transports.modbus import ModbusTransport
from asictl.host.transports.ports import parse_port
from asictl.readers.units import format_duration

#: Masters worked on at once unless the command says otherwise.
DEFAULT_JOBS = 8

T = TypeVar("T")


@dataclass(frozen=True)
class Outcome(Generic[T]):
    """What the work gave on one master, or why it failed (after ``attempts`` tries)."""

    master: FleetMaster
    value: T | None
    error: str | None
    attempts: int
    seconds: float

    @property
    def ok(self) -> bool:
        return self.error is None


def _quiet(_: str) -> None:
    """Messages about waiting go nowhere: a fleet command never waits for a held board."""


def _absent_board(master: FleetMaster) -> str | None:
    """Why an emulated board is not there: the single-master commands would make a new,
    empty one, which a backup must not mistake for the master (nor leave behind)."""
    address = master.address
    if address.modbus is not None or address.io != "emulated":
        return None
    directory = state_directory(address.state_dir)
    if state_file(directory, parse_port(address.port)).exists():
        return None
    return f"no emulated board {address.port} in {directory}"


def _attempt(master: FleetMaster, work: Callable[[FleetMaster, Master], T]) -> Outcome[T]:
    started = time.monotonic()
    deadline = started + master.limit
    error = "not tried"
    for attempt in range(1, master.attempts + 1):
        absent = _absent_board(master)
        if absent is not None:
            return Outcome(master, None, absent, attempt, time.monotonic() - started)
        try:
            with open_board(master.address, notify=_quiet) as connected:
                if isinstance(connected.transport, ModbusTransport):
                    connected.transport.deadline = deadline
                value = work(master, connected)
        except (UserError, OSError) as exc:
            error = str(exc) or type(exc).__name__
            if time.monotonic() >= deadline:
                limit = format_duration(master.limit * 1000)
                error = f"not done within its limit of {limit} ({error})"
                return Outcome(master, None, error, attempt, time.monotonic() - started)
            continue
        return Outcome(master, value, None, attempt, time.monotonic() - started)
    return Outcome(master, None, error, master.attempts, time.monotonic() - started)


def each_master(
    masters: Sequence[FleetMaster],
    work: Callable[[FleetMaster, Master], T],
    *,
    jobs: int = DEFAULT_JOBS,
    progress: Callable[[int, Outcome[T]], None] | None = None,
) -> list[Outcome[T]]:
    """``work(master, connected)`` on every master, at most ``jobs`` at once; the outcomes
    in the inventory's order. ``progress(done, outcome)`` hears each as it finishes."""
    outcomes: dict[str, Outcome[T]] = {}
    with ThreadPoolExecutor(max_workers=max(1, min(jobs, len(masters) or 1))) as pool:
        futures = [pool.submit(_attempt, master, work) for master in masters]
        for future in as_completed(futures):
            outcome = future.result()
            outcomes[outcome.master.name] = outcome
            if progress is not None:
                progress(len(outcomes), outcome)
    return [outcomes[master.name] for master in masters]
