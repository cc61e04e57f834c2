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


def tmux(server: str, *args: str, check: bool = True) -> str:
    """One tmux command on the test's own server (``-L``): no other tmux session, the
    user's or a parallel test's, can resize or share its window."""
    return subprocess.run(
        ["tmux", "-L", server, *args], capture_output=True, text=True, check=check
    ).stdout


def capture(server: str) -> str:
    return tmux(server, "capture-pane", "-p", "-t", "monitor", check=False)


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
    server = f"asictl-test-{uuid.uuid4().hex[:8]}"
    command = (
        f"PYTHONPATH={ROOT / 'src'} {sys.executable} -m asictl monitor --state-dir {state}; "
        f"echo $? > {done}"
    )
    # The terminal's size is tmux's: COLUMNS/LINES (which pytest-xdist's workers inherit
    # as 80x24) would override it for Textual.
    env = {key: value for key, value in os.environ.items() if key not in ("COLUMNS", "LINES")}
    env["TERM"] = "xterm-256color"
    subprocess.run(
        ["tmux", "-L", server, "new-session", "-d", "-s", "monitor", "-x", "170", "-y", "45",
         command],
        check=True, env=env,
    )
    try:
        shown = ("31 0000/000", "normal operation", "control program running", "PDA", "q Quit")
        assert wait_for(lambda: all(text in capture(server) for text in shown)), capture(
            server
        )
        # the blinker blinks on the screen: both values of Q 31.0 show up
        seen = set()
        wait_for(lambda: seen.update(
            {line.split("31 0000/")[1][:4] for line in capture(server).splitlines()
             if "31 0000/" in line}
        ) or len(seen) > 1, timeout=30)
        assert seen >= {"0000", "0001"}, seen
        # the program view: the source with each line's values from the latest cycle
        tmux(server, "send-keys", "-t", "monitor", "v")

        def program_view() -> bool:
            screen = capture(server)
            rows = [line for line in screen.splitlines() if "A   T 0" in line]
            return (
                "program view  blink.asi" in screen and "v Slave view" in screen
                and "ACCU1" in screen
                and any(re.search(r"still running\?\s+[01]\s+\d+\s+\d+\s+\d+\s+[01]$", line)
                        for line in rows)
                and any(re.search(r"=   Q 31.0\s+(-\s+){4}not run$", line)
                        for line in screen.splitlines())
            )

        assert wait_for(program_view), capture(server)
        tmux(server, "send-keys", "-t", "monitor", "v")
        assert wait_for(lambda: "v Program view" in capture(server)), capture(server)
        tmux(server, "send-keys", "-t", "monitor", "q")
        assert wait_for(done.exists), capture(server)
        assert done.read_text().strip() == "0"
    finally:
        tmux(server, "kill-server", check=False)
    assert not (state / "pc2-300h.sock").exists(), "the monitor's own live board stopped"


def test_at_80x24_every_slave_the_help_and_a_killed_server_taken_over(tmp_path: Path):
    """The issue's bar: at 80x24 slave 31 is on the screen and ``?`` shows the help;
    the server killed (SIGKILL: its socket is left behind), the screen says 'took over'
    within 3 s and the board runs on."""
    assert shutil.which("tmux"), "tmux is needed to test the monitor in a real terminal"
    state = tmp_path / "state"
    result = CliRunner().invoke(main, ["download", str(BLINK), "--start", "--state-dir",
                                       str(state)])
    assert result.exit_code == 0, result.output
    env = {key: value for key, value in os.environ.items() if key not in ("COLUMNS", "LINES")}
    env["PYTHONPATH"] = str(ROOT / "src")
    serve = subprocess.Popen(
        [sys.executable, "-m", "asictl", "serve", "--state-dir", str(state)],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    done = tmp_path / "exit-status"
    server = f"asictl-test-{uuid.uuid4().hex[:8]}"
    command = (
        f"{sys.executable} -m asictl monitor --state-dir {state}; echo $? > {done}"
    )
    env["TERM"] = "xterm-256color"
    try:
        assert wait_for(lambda: (state / "pc2-300h.sock").exists()), "asictl serve started"
        subprocess.run(
            ["tmux", "-L", server, "new-session", "-d", "-s", "monitor", "-x", "80", "-y",
             "24", command], check=True, env=env,
        )
        shown = ("31 0000/000", "control program running", "served by asictl", "? Help")
        assert wait_for(lambda: all(text in capture(server) for text in shown)), capture(
            server
        )
        tmux(server, "send-keys", "-t", "monitor", "?")
        assert wait_for(lambda: "this help" in capture(server)
                        and "force OPERAND=VALUE" in capture(server)), capture(server)
        tmux(server, "send-keys", "-t", "monitor", "Escape")
        assert wait_for(lambda: "this help" not in capture(server)), capture(server)
        serve.kill()
        killed = time.monotonic()
        assert wait_for(lambda: "took over" in capture(server), timeout=3.0), capture(server)
        print(f"'took over' on the screen {time.monotonic() - killed:.2f} s after SIGKILL")
        # the board runs on: the blinker's Q 31.0 still changes on the screen
        seen: set[str] = set()
        wait_for(lambda: seen.update(
            {line.split("31 0000/")[1][:4] for line in capture(server).splitlines()
             if "31 0000/" in line}
        ) or len(seen) > 1, timeout=30)
        assert seen >= {"0000", "0001"}, seen
        tmux(server, "send-keys", "-t", "monitor", "F10")
        assert wait_for(done.exists), capture(server)
        assert done.read_text().strip() == "0"
    finally:
        tmux(server, "kill-server", check=False)
        serve.kill()
        serve.wait()
    assert not (state / "pc2-300h.sock").exists(), "the monitor's own live board stopped"
