"""What the monitor's tests share: the CLI against a state directory, a live board
running a program, and letting a Textual app refresh."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from click.testing import CliRunner

from asictl.cli import main
from asictl.host.live.server import background_live
from asictl.monitor.app import MonitorApp

#: Q 17.3 follows I 4.0: a slave a key sets and one whose output shows it
PROGRAM = """\
[SETUP]
4: iiii, 0
17: oooo, 0

[PROGRAM]
        A   I 4.0
        =   Q 17.3
        BE
[END]
"""


def cli(state: Path, *args: str) -> str:
    result = CliRunner().invoke(main, [*args, "--state-dir", str(state)])
    assert result.exit_code == 0, result.output
    return result.stdout


@contextmanager
def live(tmp_path: Path, program: Path | str, name: str = "p.asi") -> Iterator[Path]:
    """A live board at 300h running ``program`` (a file, or source text to write as
    ``name``) with its slaves on the bus; yields the state directory."""
    if isinstance(program, str):
        path = tmp_path / name
        path.write_text(program)
        program = path
    state = tmp_path / "state"
    with background_live(0x300, state, identity={"command": "test"}):
        cli(state, "download", str(program), "--start")
        cli(state, "bus", "match")
        yield state


async def settle(app: MonitorApp, pilot, refreshes: int = 2) -> None:
    """Let running actions finish and the screen refresh a few times."""
    await app.workers.wait_for_complete()
    target = app.refreshes + refreshes
    for _ in range(200):
        if app.refreshes >= target:
            break
        app.refresh_now()
        await pilot.pause(0.02)
    await app.workers.wait_for_complete()
