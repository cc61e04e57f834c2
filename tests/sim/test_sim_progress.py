"""A long simulation's progress: the engine reports how far it is once a second of
master time without changing the run, and ``asictl sim`` shows it on a terminal."""

from __future__ import annotations

import io
import itertools
from pathlib import Path

from asictl.cli.sim import _SimProgress
from asictl.sim.engine import PROGRESS_MS
from asictl.sim.session import prepare, simulate

ROOT = Path(__file__).resolve().parents[2]


def test_progress_is_reported_and_the_run_is_the_same(tmp_path: Path):
    scenario = tmp_path / "blink.scenario.toml"
    scenario.write_text((ROOT / "demos" / "blink.scenario.toml").read_text()
                        + '\n[[step]]\nat = "5s"\nexpect = { "Q 31.0" = 1 }\n')
    program = ROOT / "demos" / "blink.asi"
    reports: list[tuple[float, float]] = []
    quiet = simulate(prepare(program, scenario))
    watched = simulate(prepare(program, scenario), progress=lambda *a: reports.append(a))
    assert [f.got for f in watched.result.failures] == [f.got for f in quiet.result.failures]
    assert watched.result.checked == quiet.result.checked
    assert watched.result.final == quiet.result.final
    assert [at for at, _ in reports] == sorted(at for at, _ in reports)
    assert len(reports) >= 3 and all(end == quiet.result.end_ms for _, end in reports)
    assert all(b - a >= PROGRESS_MS - 1 for (a, _), (b, _) in itertools.pairwise(reports))


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_the_progress_line_waits_a_second_then_shows_and_clears(monkeypatch):
    terminal = _Terminal()
    monkeypatch.setattr("sys.stderr", terminal)
    progress = _SimProgress()
    assert progress.enabled
    progress(1000.0, 60000.0)
    assert terminal.getvalue() == ""  # a short run shows nothing
    progress.begun -= 2
    progress(30000.0, 60000.0)
    assert terminal.getvalue() == "\r\x1b[K[sim] 30 s of 1 min 0 s master time (50%)"
    progress.clear()
    assert terminal.getvalue().endswith("\r\x1b[K") and not progress.shown
