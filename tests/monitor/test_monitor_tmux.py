"""``asictl monitor`` in a real terminal: tmux runs it, capture-pane reads the screen.

tmux is a test dependency (.ci/run installs it); without it this test fails rather than
hiding that the monitor was never seen in a terminal.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
import uuid
from pathlib import Path

from click.testing import CliRunner

from asictl.cli import main

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"


def capture(session: str) -> str:
    return subprocess.run(
        ["tmux", "capture-pane", "-p", "-t", session], capture_output=True, text=True
    ).stdout


def wait_for(predicate, timeout: float = 20.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.2)
    return False


def test_the_monitor_shows_the_slaves_in_tmux_and_q_quits(tmp_path: Path):
    assert shutil.which("tmux"), "tmux is needed to test the monitor in a real terminal"
    state = tmp_path / "state"
    result = CliRunner().invoke(main, ["download", str(BLINK), "--start", "--state-dir",
                                       str(state)])
    assert result.exit_code == 0, result.output
    done = tmp_path / "exit-status"
    session = f"asictl-test-{uuid.uuid4().hex[:8]}"
    command = (
        f"PYTHONPATH={ROOT / 'src'} {sys.executable} -m asictl monitor --state-dir {state}; "
        f"echo $? > {done}"
    )
    env = {**os.environ, "TERM": "xterm-256color"}
    subprocess.run(
        ["tmux", "new-session", "-d", "-s", session, "-x", "170", "-y", "45", command],
        check=True, env=env,
    )
    try:
        shown = ("31 0000/000", "normal operation", "control program running", "PDA", "q Quit")
        assert wait_for(lambda: all(text in capture(session) for text in shown)), capture(
            session
        )
        # the blinker blinks on the screen: both values of Q 31.0 show up
        seen = set()
        wait_for(lambda: seen.update(
            {line.split("31 0000/")[1][:4] for line in capture(session).splitlines()
             if "31 0000/" in line}
        ) or len(seen) > 1, timeout=10)
        assert seen >= {"0000", "0001"}, seen
        # the program view: the source with each line's values from the latest cycle
        subprocess.run(["tmux", "send-keys", "-t", session, "v"], check=True)

        def program_view() -> bool:
            screen = capture(session)
            rows = [line for line in screen.splitlines() if "A   T 0" in line]
            return (
                "program view  blink.asi" in screen and "v Slave view" in screen
                and "ACCU1" in screen
                and any(re.search(r"still running\?\s+[01]\s+\d+\s+\d+\s+[01]$", line)
                        for line in rows)
                and any(re.search(r"=   Q 31.0\s+(-\s+){3}not run$", line)
                        for line in screen.splitlines())
            )

        assert wait_for(program_view), capture(session)
        subprocess.run(["tmux", "send-keys", "-t", session, "v"], check=True)
        assert wait_for(lambda: "v Program view" in capture(session)), capture(session)
        subprocess.run(["tmux", "send-keys", "-t", session, "q"], check=True)
        assert wait_for(done.exists), capture(session)
        assert done.read_text().strip() == "0"
    finally:
        subprocess.run(["tmux", "kill-session", "-t", session], capture_output=True)
    assert not (state / "pc2-300h.sock").exists(), "the monitor's own live board stopped"
