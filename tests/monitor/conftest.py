"""The monitor's Textual tests run beside a live board in a thread of the same process."""

from __future__ import annotations

import asyncio
import time

import pytest
import textual.app


async def _wait_for_idle(min_sleep: float = 0.0, max_sleep: float = 1.0) -> None:
    """Textual's ``wait_for_idle``, measured on the app's own thread.

    Textual's pilot waits, after each key, until the *process* has used almost no CPU
    for 20 ms, for at most a second. Beside it here a live board runs its program
    in another thread, so the process never looks idle and each key took up to two
    seconds. The app's own thread going quiet is what the pilot means."""
    start = time.monotonic()
    while True:
        cpu = time.thread_time()
        await asyncio.sleep(1 / 50)
        elapsed = time.monotonic() - start
        if elapsed >= max_sleep or (elapsed > min_sleep and time.thread_time() - cpu < 1 / 1000):
            return


@pytest.fixture(autouse=True)
def _idle_is_the_apps_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(textual.app, "wait_for_idle", _wait_for_idle)
