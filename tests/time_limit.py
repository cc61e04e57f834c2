"""A hang detector for tests of inputs that once made asictl run forever.

It is not a performance threshold: the limit is far above any real run and only turns
a hang into a failure instead of a stuck test suite.
"""

from __future__ import annotations

import signal
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType


class Hung(Exception):
    """The block ran past its limit."""


@contextmanager
def no_hang(seconds: float = 30.0) -> Iterator[None]:
    """Fail with ``Hung`` if the block runs longer than ``seconds`` (main thread only)."""

    def expire(signum: int, frame: FrameType | None) -> None:
        raise Hung(f"still running after {seconds} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
