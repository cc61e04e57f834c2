"""``asictl record`` under ``asictl serve``: inputs changed with ``bus inputs`` while it
records, the recording replayed with ``asictl sim`` against the program (passes) and
against a changed one (fails at the first divergence, naming the line that wrote it)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

from click.testing import CliRunner
from live_helpers import OR_PROGRAM, ROOT, cli, start_serve, stop
from served_gateway import serve_gateway

from asictl.cli import main


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
    window = re.search(r"within_ms = (\d+)", text)
    assert 'program = "or.asi"' in text and window and int(window[1]) >= 100, text
    assert text.count('set = { "I 4.0" = 1 }') == 1, text
    assert "samples over" in err
    replay = CliRunner().invoke(main, ["sim", str(program), "--scenario", str(out)])
    assert replay.exit_code == 0, replay.output
    assert ", 0 failed" in replay.output
    bad = CliRunner().invoke(main, ["sim", str(changed), "--scenario", str(out)])
    assert bad.exit_code == 1, bad.output
    first = bad.output.splitlines()[0]
    assert (f"(within {window[1]} ms): Q 17.3 expected 1, got 0; last written by and.asi:9"
            in first), bad.output
    again = cli(state, "record", "--duration", "1s", "-o", str(out))
    assert again.exit_code == 2 and "not overwritten (use --force)" in again.output
    assert out.read_text() == text


def test_a_board_that_is_not_served_is_refused_with_the_way_to_serve_it(tmp_path: Path):
    state = tmp_path / "state"
    result = cli(state, "record", "--duration", "1s", "-o", str(tmp_path / "r.scenario.toml"))
    assert result.exit_code == 2, result.output
    assert "serve it first ('asictl serve --port 300h')" in result.output
    assert not (tmp_path / "r.scenario.toml").exists()


def test_a_gateway_is_recorded_through_modbus(tmp_path: Path):
    program = tmp_path / "or.asi"
    program.write_text(OR_PROGRAM)
    state = tmp_path / "state"
    out = tmp_path / "gw.scenario.toml"
    assert cli(state, "download", str(program), "--start").exit_code == 0
    assert cli(state, "bus", "match").exit_code == 0
    with serve_gateway(state) as (port, _):
        recorder = subprocess.Popen(
            [sys.executable, "-m", "asictl", "record", "--modbus", f"tcp://127.0.0.1:{port}",
             "--duration", "4s", "-o", str(out), "--signals", "I 4.0,I 5.0,Q 17.3"],
            stderr=subprocess.PIPE, text=True,
            env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
        )
        assert recorder.stderr is not None
        assert "recording tcp://127.0.0.1" in recorder.stderr.readline()
        time.sleep(0.5)
        assert cli(state, "bus", "inputs", "I 5.0=1").exit_code == 0
        _, err = recorder.communicate(timeout=60)
        assert recorder.returncode == 0, err
    text = out.read_text()
    assert 'set = { "I 5.0" = 1 }' in text and 'expect = { "Q 17.3" = 1 }' in text, text
    replay = CliRunner().invoke(main, ["sim", str(program), "--scenario", str(out)])
    assert replay.exit_code == 0, replay.output
