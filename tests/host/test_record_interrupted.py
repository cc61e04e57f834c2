"""``asictl record`` streams its samples to disk and keeps what it has: memory stays the
same over a long recording, and SIGTERM, SIGHUP, Ctrl-C or a served board that is killed
leave a whole scenario that ``asictl sim`` reads, with a message saying what ended it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import pytest
from click.testing import CliRunner
from live_helpers import OR_PROGRAM, ROOT, cli, start_serve, stop

from asictl.cli import main
from asictl.sim.recording import Recording

#: 124 signals, as the recording that grew to 193 MB in two minutes
SIGNALS = [f"I {a}.{b}" for a in range(1, 32) for b in range(4)][:62] + \
    [f"Q {a}.{b}" for a in range(1, 32) for b in range(4)][:62]


def _peak(samples: int) -> int:
    """The most memory a recording of ``samples`` samples of 124 signals (a tenth of
    them changing each time) holds at once, writing its scenario included."""
    inputs, outputs = SIGNALS[:62], SIGNALS[62:]
    with tempfile.TemporaryFile("w+") as spool, open(os.devnull, "w") as out:
        tracemalloc.start()
        try:
            recording = Recording(inputs, outputs, spool)
            values = dict.fromkeys(SIGNALS, 0)
            for index in range(samples):
                for name in SIGNALS[index % 10::10]:
                    values[name] ^= 1
                recording.add(index * 20.0, values)
            recording.write(out, 100)
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()


def test_memory_stays_the_same_however_long_it_records():
    short, long = _peak(500), _peak(10_000)  # 10 s and 200 s at 20 ms a sample
    assert long < short * 1.5 + 64_000, (short, long)


def _recorder(state: Path, out: Path, program: Path, duration: str = "60s"
              ) -> subprocess.Popen[str]:
    recorder = subprocess.Popen(
        [sys.executable, "-m", "asictl", "record", "--duration", duration, "-o", str(out),
         "--program", str(program), "--signals", "I 4.0,I 5.0,Q 17.*",
         "--state-dir", str(state)],
        stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
    )
    assert recorder.stderr is not None
    assert "recording 300h" in recorder.stderr.readline()
    return recorder


def _replays(program: Path, out: Path) -> None:
    replay = CliRunner().invoke(main, ["sim", str(program), "--scenario", str(out)])
    assert replay.exit_code == 0, replay.output
    assert ", 0 failed" in replay.output


@pytest.fixture
def served(tmp_path: Path):
    program = tmp_path / "or.asi"
    program.write_text(OR_PROGRAM)
    state = tmp_path / "state"
    server = start_serve(state)
    try:
        assert cli(state, "download", str(program), "--start").exit_code == 0
        assert cli(state, "bus", "match").exit_code == 0
        yield state, program, server
    finally:
        stop(server)


def _ended(state: Path, program: Path, tmp_path: Path, change: str,
           end: Callable[[subprocess.Popen[str]], None]) -> tuple[int, str, str]:
    """Record, change an input, ``end`` the recording; its exit status, its standard
    error and the scenario it wrote (which must have the change once and replay)."""
    out = tmp_path / "run.scenario.toml"
    recorder = _recorder(state, out, program)
    time.sleep(0.5)
    assert cli(state, "bus", "inputs", change).exit_code == 0
    time.sleep(0.5)
    end(recorder)
    _, err = recorder.communicate(timeout=60)
    assert "Traceback" not in err
    text = out.read_text()
    operand, value = change.split("=")
    assert text.count(f'set = {{ "{operand}" = {value} }}') == 1, text
    _replays(program, out)
    return recorder.returncode, err, text


@pytest.mark.parametrize(("sent", "said"), [(signal.SIGTERM, "SIGTERM"),
                                             (signal.SIGHUP, "SIGHUP"),
                                             (signal.SIGINT, "Ctrl-C")])
def test_a_signal_ends_the_recording_and_keeps_a_whole_scenario(served, tmp_path: Path,
                                                                sent: int, said: str):
    state, program, _ = served
    code, err, _ = _ended(state, program, tmp_path, "I 4.0=1",
                          lambda recorder: recorder.send_signal(sent))
    assert code == 0, err
    assert f"recording ended early: {said}" in err
    assert "samples over" in err
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_a_killed_server_ends_the_recording_and_keeps_a_whole_scenario(served,
                                                                       tmp_path: Path):
    state, program, server = served

    def kill_server(_recorder: subprocess.Popen[str]) -> None:
        server.kill()
        server.wait(timeout=10)

    code, err, _ = _ended(state, program, tmp_path, "I 5.0=1", kill_server)
    assert code == 1, err
    assert "recording ended early: the board stopped answering" in err
