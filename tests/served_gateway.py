"""``asictl gateway serve`` in a process of its own, as a user starts it (imported
explicitly: ``from served_gateway import serve_gateway``)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def serve_gateway(state: Path, *options: str) -> Iterator[tuple[int, list[str]]]:
    """The gateway for the boards in ``state`` on a free TCP port; yields that port and
    the lines it wrote before it served. Ctrl-C ends it, which must exit 0."""
    env = {**os.environ, "ASICTL_STATE_DIR": str(state)}
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", "gateway", "serve", "--tcp", "127.0.0.1:0", *options],
        stderr=subprocess.PIPE, text=True, env=env,
    )
    assert process.stderr is not None
    try:
        lines = []
        while not lines or "serving" not in lines[-1]:
            line = process.stderr.readline()
            assert line, "".join(lines) + "the gateway ended"
            lines.append(line)
        match = re.search(r"tcp 127\.0\.0\.1:(\d+)", lines[-1])
        assert match, lines
        yield int(match.group(1)), lines
    finally:
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=20) == 0


@contextmanager
def serve_gateways(states: list[Path], *options: str) -> Iterator[list[int]]:
    """A gateway for each state directory (its board 300h), all started at once; yields
    their TCP ports in the same order. Ctrl-C ends each, which must exit 0."""
    processes = [
        subprocess.Popen(
            [sys.executable, "-m", "asictl", "gateway", "serve", "--tcp", "127.0.0.1:0",
             *options],
            stderr=subprocess.PIPE, text=True, env={**os.environ, "ASICTL_STATE_DIR": str(s)},
        )
        for s in states
    ]
    try:
        ports = []
        for process in processes:
            assert process.stderr is not None
            lines: list[str] = []
            while not lines or "serving" not in lines[-1]:
                line = process.stderr.readline()
                assert line, "".join(lines) + "the gateway ended"
                lines.append(line)
            match = re.search(r"tcp 127\.0\.0\.1:(\d+)", lines[-1])
            assert match, lines
            ports.append(int(match.group(1)))
        yield ports
    finally:
        for process in processes:
            process.send_signal(signal.SIGINT)
        for process in processes:
            assert process.wait(timeout=30) == 0
