"""What the host's command-line tests share."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner, Result

from asictl.cli import main


@pytest.fixture
def run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """``asictl ARGS --state-dir DIR`` as a user runs it, in a fresh folder with a state
    directory of its own (``run.state_dir``); never a traceback."""
    monkeypatch.chdir(tmp_path)
    state_dir = tmp_path / "state"

    def invoke(*args: str) -> Result:
        result = CliRunner().invoke(main, [*args, "--state-dir", str(state_dir)])
        assert "Traceback" not in result.output
        return result

    invoke.state_dir = state_dir  # type: ignore[attr-defined]
    return invoke
