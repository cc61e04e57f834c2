"""The monitor's online keys: forcing and releasing (marked, counted on top), the watch
view, a slave's parameter, the hi-flags, and symbol names beside operands; each checked
on the board through the commands' own path."""

from __future__ import annotations

import asyncio
import json
import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from monitor_harness import PROGRAM, cli, live, settle

from asictl.host.connection import MasterAddress
from asictl.host.live.client import open_live
from asictl.monitor.app import MonitorApp
from asictl.monitor.source import MonitorSource

ROOT = Path(__file__).resolve().parents[2]
SYMBOLS = 'Start = "I 4.0"\nLamp = "Q 17.3"\nMark = "F 10.0"\n'


@pytest.fixture
def board(tmp_path: Path) -> Iterator[Path]:
    (tmp_path / "p.symbols.toml").write_text(SYMBOLS)
    with live(tmp_path, PROGRAM) as state:
        yield state


def status(state: Path) -> dict:
    return json.loads(cli(state, "status", "--json"))


def text(app: MonitorApp, widget: str) -> str:
    return re.sub(r"[ \t]+", " ", str(app.query_one(f"#{widget}").render()))


def log_text(app: MonitorApp) -> str:
    return re.sub(r"\s+", " ", " ".join(line.text for line in app.query_one("#log").lines))


def run(state: Path, check, size: tuple[int, int] = (120, 40)) -> None:
    app = MonitorApp(MonitorSource(MasterAddress(state_dir=state)))

    async def main_() -> None:
        async with app.run_test(size=size) as pilot:
            await settle(app, pilot)
            await check(app, pilot)

    asyncio.run(main_())


async def enter(app: MonitorApp, pilot, key: str, typed: str, clear: int = 0) -> None:
    await pilot.press(key)
    await pilot.press(*["backspace"] * clear, *typed, "enter")
    await settle(app, pilot, 3)


def test_force_by_name_holds_the_output_and_release_all_lets_go(board):
    async def check(app, pilot):
        await enter(app, pilot, "F", "Lamp=1")
        forced = status(board)["forced"]
        assert [f["operand"] for f in forced] == ["Q 17.3"], forced
        assert status(board)["slaves"]["17"]["outputs"] == 8, "held though I 4.0 is 0"
        assert "FORCE 1" in text(app, "top")
        app.selected = 17
        await settle(app, pilot)
        assert "forced Q 17.3 (Lamp) = 1" in text(app, "detail")
        assert "names Lamp = Q 17.3" in text(app, "detail")
        assert "forced FORCE 1: Q 17.3 (Lamp) = 1" in text(app, "under")
        await enter(app, pilot, "F", "I 4.0=1")
        assert "FORCE 2" in text(app, "top")
        await enter(app, pilot, "R", "Lamp")
        assert [f["operand"] for f in status(board)["forced"]] == ["I 4.0"]
        assert status(board)["slaves"]["17"]["outputs"] == 8, "the forced input drives it"
        await enter(app, pilot, "R", "all")
        await settle(app, pilot, 4)
        assert status(board)["forced"] == [] and "FORCE" not in text(app, "top")
        assert status(board)["slaves"]["17"]["outputs"] == 0
        await enter(app, pilot, "F", "T 0=1")
        assert "cannot be forced" in log_text(app), "a bad force is reported, not fatal"

    run(board, check)


def test_parameter_and_hi_flags_keys(board):
    async def check(app, pilot):
        app.selected = 4
        await enter(app, pilot, "P", "5")
        assert status(board)["slaves"]["4"]["pi"] == 5
        assert "slave 4 got parameter 5h" in log_text(app)
        await enter(app, pilot, "h", "offline no-auto-address")
        assert status(board)["hi_flags"] & 0x06 == 0x06
        await enter(app, pilot, "h", "--online auto-address")
        assert status(board)["hi_flags"] & 0x06 == 0
        await enter(app, pilot, "h", "sideways")
        assert "'sideways': the hi-flags are" in log_text(app)

    run(board, check)


def test_the_watch_view_writes_once_forces_and_releases_the_selected_row(board):
    async def check(app, pilot):
        await pilot.press("w")
        await settle(app, pilot)
        assert "nothing watched yet" in text(app, "watch")
        await enter(app, pilot, "plus", "Start, FY 10, Mark")
        rows = text(app, "watch")
        assert "I 4.0 (Start)" in rows and "FY 10" in rows and "F 10.0 (Mark)" in rows
        await pilot.press("down")  # FY 10
        await enter(app, pilot, "equals_sign", "0x12")  # the prompt holds 'FY 10='
        assert status(board)["flags"][10] == 0x12
        assert re.search(r"FY 10 +10010 +18 +12h", text(app, "watch")), text(app, "watch")
        await enter(app, pilot, "F", "0x55")
        assert status(board)["forced"][0]["operand"] == "FY 10"
        assert re.search(r"FY 10 +1010101 +85 +55h +FORCED", text(app, "watch"))
        # a bit is held by its forced flag byte
        assert re.search(r"F 10\.0 \(Mark\) +1 +1 +1h +FORCED", text(app, "watch"))
        await enter(app, pilot, "R", "")  # the prompt holds 'FY 10'
        assert status(board)["forced"] == []
        await pilot.press("minus")
        await settle(app, pilot)
        assert "FY 10" not in text(app, "watch") and "F 10.0 (Mark)" in text(app, "watch")
        await enter(app, pilot, "plus", "Nobody")
        assert "watch Nobody:" in log_text(app)

    run(board, check)


def test_the_watch_view_shows_a_condition_as_a_bit(board):
    async def check(app, pilot):
        await pilot.press("w")
        await settle(app, pilot)
        await enter(app, pilot, "plus", "Start or Mark")
        assert re.search(r"Start or Mark +0 +0 +0h", text(app, "watch")), text(app, "watch")
        cli(board, "write", "Mark=1")
        await settle(app, pilot, 4)
        assert re.search(r"Start or Mark +1 +1 +1h", text(app, "watch")), text(app, "watch")
        await pilot.press("F")  # a condition is no operand: the prompt starts empty
        assert app.query_one("#prompt").value == ""

    run(board, check)


def test_the_program_view_names_operands_by_the_boards_symbol_table(board):
    async def check(app, pilot):
        await pilot.press("v")
        await settle(app, pilot)
        rows = {line.split()[0]: line for line in text(app, "program").splitlines()
                if line.split() and line.split()[0].isdigit()}
        assert rows["6"].endswith("0 (Start)"), rows["6"]
        assert rows["7"].endswith("0 (Lamp)"), rows["7"]

    run(board, check)


def asictl_process(state: Path, *args: str) -> int:
    """``asictl ARGS`` in a process of its own, as another user of the board runs it;
    its pid, once it ended well without waiting for the board aloud."""
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", *args, "--state-dir", str(state)],
        env={**os.environ, "PYTHONPATH": str(ROOT / "src")}, stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE, text=True)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 0 and "waiting" not in stderr, stderr
    return process.pid


def test_other_clients_changes_are_logged_with_their_names_and_their_reads_never(board):
    """A change by another command shows as one line naming it; another client's reads
    (a status, as a second monitor's refreshes are) and this monitor's waits do not."""

    async def check(app, pilot):
        pid = await asyncio.to_thread(asictl_process, board, "force", "Lamp=1")
        await asyncio.to_thread(asictl_process, board, "status")
        holder = open_live(board, 0x300)
        assert holder is not None
        with holder.session("a long command"):  # the monitor's refreshes wait meanwhile
            await asyncio.sleep(1.5)
        holder.close()
        await settle(app, pilot, 3)
        log = log_text(app)
        assert log.count(f"FORCE Q 17.3 (Lamp)=1 by asictl force (pid {pid})") == 1, log
        assert "asictl status" not in log and "waiting for" not in log, log

    run(board, check)
