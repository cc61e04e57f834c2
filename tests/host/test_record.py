"""``asictl record`` under ``asictl serve``: inputs changed with ``bus inputs`` while it
records, the recording replayed with ``asictl sim`` against the program (passes) and
against a changed one (fails at the first divergence, naming the line that wrote it)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

from click.testing import CliRunner
from live_helpers import ROOT, cli, start_serve, stop

from asictl.cli import main

OR_PROGRAM = """\
[SETUP]
4: iiii, 0
5: iiii, 0
17: oooo, 0

[PROGRAM]
        O   I 4.0
        O   I 5.0
        =   Q 17.3
        BE
[END]
"""


def test_a_recording_replays_against_its_program_and_not_a_changed_one(tmp_path: Path):
    program = tmp_path / "or.asi"
    program.write_text(OR_PROGRAM)
    changed = tmp_path / "and.asi"
    changed.write_text(OR_PROGRAM.replace("O   I 5.0", "A   I 5.0"))
    state = tmp_path / "state"
    out = tmp_path / "run.scenario.toml"
    server = start_serve(state)
    try:
        assert cli(state, "download", str(program), "--start").exit_code == 0
        assert cli(state, "bus", "match").exit_code == 0
        recorder = subprocess.Popen(
            [sys.executable, "-m", "asictl", "record", "--duration", "5s", "-o", str(out),
             "--program", str(program), "--signals", "I 4.0,I 5.0,Q 17.*",
             "--state-dir", str(state)],
            stderr=subprocess.PIPE, text=True,
            env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
        )
        assert recorder.stderr is not None
        assert "recording 300h for 5 s" in recorder.stderr.readline()  # it samples now
        time.sleep(0.5)
        for change in ("I 4.0=1", "I 5.0=1", "I 4.0=0", "I 5.0=0"):
            assert cli(state, "bus", "inputs", change).exit_code == 0
            time.sleep(0.4)
        _, err = recorder.communicate(timeout=60)
        assert recorder.returncode == 0, err
    finally:
        assert stop(server) == 0
    text = out.read_text()
    assert 'program = "or.asi"' in text and "within_ms = 100" in text
    assert text.count('set = { "I 4.0" = 1 }') == 1, text
    assert "samples over" in err
    replay = CliRunner().invoke(main, ["sim", str(program), "--scenario", str(out)])
    assert replay.exit_code == 0, replay.output
    assert ", 0 failed" in replay.output
    bad = CliRunner().invoke(main, ["sim", str(changed), "--scenario", str(out)])
    assert bad.exit_code == 1, bad.output
    first = bad.output.splitlines()[0]
    assert "(within 100 ms): Q 17.3 expected 1, got 0; last written by and.asi:9" in first, \
        bad.output
    again = cli(state, "record", "--duration", "1s", "-o", str(out))
    assert again.exit_code == 2 and "not overwritten (use --force)" in again.output
    assert out.read_text() == text


def test_a_board_that_is_not_served_is_refused_with_the_way_to_serve_it(tmp_path: Path):
    state = tmp_path / "state"
    result = cli(state, "record", "--duration", "1s", "-o", str(tmp_path / "r.scenario.toml"))
    assert result.exit_code == 2, result.output
    assert "serve it first ('asictl serve --port 300h')" in result.output
    assert not (tmp_path / "r.scenario.toml").exists()
