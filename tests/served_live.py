"""A live board's server (``serve``, ``gateway serve``) in its own process for a test, as
a user starts it (import it explicitly: ``from served_live import served_live``)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def served_live(
    state: Path, command: Sequence[str], said: str, *, env: dict[str, str] | None = None,
    also: str | None = None,
) -> Iterator[str]:
    """``asictl COMMAND...`` with ``state`` as its state folder; yields the first group of
    ``said`` (a pattern of its standard error: where it serves) once it has said that,
    and a line containing ``also`` if given; stopped by SIGINT, which must end it
    cleanly."""
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", *command], stderr=subprocess.PIPE, text=True,
        env={**os.environ, "ASICTL_STATE_DIR": str(state), **(env or {})},
    )
    assert process.stderr is not None
    try:
        lines: list[str] = []
        found = None
        while found is None or (also is not None and not any(also in x for x in lines)):
            line = process.stderr.readline()
            assert line, "".join(lines) + "the server ended"
            lines.append(line)
            found = found or re.search(said, line)
        yield found.group(1)
    finally:
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=30) == 0
