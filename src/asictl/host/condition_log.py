"""Logging a condition that may repeat thousands of times a second as a few lines.

A flood of connections, a state file that cannot be saved every 10 s: each is one line
when it starts, then at most one a minute with the number of events since, so the log
stays readable and the process does not spend its time writing it.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

#: A condition that goes on is logged again at most this often, with a count.
LOG_INTERVAL_S = 60.0


@dataclass
class ConditionLog:
    """Logs a condition once when it starts, then at most every ``interval`` seconds with
    the number of events since: a flood of connections must not become a flood of lines."""

    log: Callable[[str], None]
    interval: float = LOG_INTERVAL_S
    clock: Callable[[], float] = time.monotonic
    _last: dict[str, float] = field(default_factory=dict)
    _count: dict[str, int] = field(default_factory=dict)

    def event(self, condition: str, message: str) -> None:
        """One event of ``condition``; ``message`` says what happens (logged when due)."""
        now = self.clock()
        self._count[condition] = self._count.get(condition, 0) + 1
        last = self._last.get(condition)
        if last is not None and now - last < self.interval:
            return
        count = self._count.pop(condition)
        self._last[condition] = now
        times = "" if last is None else f" ({count} times in the last {now - last:.0f} s)"
        self.log(f"{message}{times}")

    def loop_handler(
        self, who: str
    ) -> Callable[[asyncio.AbstractEventLoop, dict[str, Any]], None]:
        """An asyncio exception handler logging the loop's own troubles (above all accept()
        failing when the process is out of descriptors, which asyncio retries every
        second) as one line per condition, each line starting with ``who``."""

        def handle(loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
            message = str(context.get("message", "event loop error"))
            exception = context.get("exception")
            detail = f": {exception}" if exception is not None else ""
            self.event(message, f"{who}: {message}{detail}")

        return handle
