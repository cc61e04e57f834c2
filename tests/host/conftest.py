"""What the host's command-line tests share."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
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


@pytest.fixture
def open_folder() -> Iterator[Path]:
    """A folder every user can walk into (pytest's own are root's alone), for the tests
    with a second local user (two_users.py)."""
    folder = Path(tempfile.mkdtemp(prefix="asictl-two-users-", dir="/tmp"))
    folder.chmod(0o755)
    try:
        yield folder
    finally:
        shutil.rmtree(folder)
