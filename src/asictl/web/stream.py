"""Pushing the board's changes to the page: a refresh reads the board every ``interval``
while anyone listens and hands each listener the newest reading.

A listener holds at most one reading not yet sent (a newer one replaces it), so a slow
client, or one that never reads, costs one reading's memory and never holds up the
refresh or the board: nothing here ever waits for a client.
"""

from __future__ import annotations

import asyncio
import json
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from asictl.errors import UserError
from asictl.host.status import MasterStatus, status_events

#: Events kept for a page that connects later.
EVENTS_KEPT = 100


@dataclass(frozen=True)
class Reading:
    """One reading of the board: its status, and the ``status --json`` text of it."""

    status: MasterStatus
    text: str
    #: the wall-clock time (seconds) it was read at
    at: float


@dataclass(eq=False)
class Listener:
    """One page (or script) listening; ``wake`` is set when ``latest`` is new."""

    latest: Reading | None = None
    wake: asyncio.Event = field(default_factory=asyncio.Event)

    def offer(self, reading: Reading) -> None:
        self.latest = reading
        self.wake.set()

    async def next(self, timeout: float) -> Reading | None:
        """The newest reading not yet taken, or None after ``timeout`` seconds."""
        try:
            await asyncio.wait_for(self.wake.wait(), timeout)
        except TimeoutError:
            return None
        self.wake.clear()
        return self.latest


@dataclass
class Hub:
    """The listeners, the latest reading and the event log."""

    listeners: set[Listener] = field(default_factory=set)
    latest: Reading | None = None
    events: deque[dict[str, Any]] = field(default_factory=lambda: deque(maxlen=EVENTS_KEPT))
    serial: int = 0

    def publish(self, status: MasterStatus) -> None:
        """A reading; listeners hear it only if it changed anything."""
        text = json.dumps(status.to_json(), separators=(",", ":"))
        if self.latest is not None and self.latest.text == text:
            return
        if self.latest is None:
            self.event(f"{status.phase}, {status.mode} mode, control program "
                       f"{status.control_state}")
        else:
            for event in status_events(self.latest.status, status):
                self.event(event)
        self.latest = Reading(status, text, time.time())
        for listener in self.listeners:
            listener.offer(self.latest)

    def changes(self, texts: list[str]) -> None:
        """Clients' changes of the board: events the listeners hear at once, even where
        the status shows none (a program downloaded again)."""
        for text in texts:
            self.event(text)
        if texts and self.latest is not None:
            for listener in self.listeners:
                listener.offer(self.latest)

    def event(self, text: str) -> None:
        self.serial += 1
        self.events.append({"id": self.serial, "time": time.time(), "text": text})

    def failed(self, error: UserError) -> None:
        """A refresh the board did not answer (it is in reset, say): an event, once."""
        text = f"master gone: {error}"
        if not self.events or self.events[-1]["text"] != text:
            self.event(text)
