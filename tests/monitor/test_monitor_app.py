"""The monitor under Textual's own test harness: every key, against a live emulated board.

The board runs live from a thread (as the monitor runs it when no 'asictl serve' does);
each test reads the board back through the commands' own path, apart from the screen.
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import Iterator
from pathlib import Path

import pytest
from monitor_harness import PROGRAM, cli, live, settle

from asictl.host.connection import MasterAddress
from asictl.monitor.app import MonitorApp
from asictl.monitor.source import MonitorSource

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"


def status(state: Path) -> dict:
    return json.loads(cli(state, "status", "--json"))


@pytest.fixture
def board(tmp_path: Path) -> Iterator[Path]:
    with live(tmp_path, PROGRAM) as state:
        yield state



def run(state: Path, keys_and_checks) -> None:
    app = MonitorApp(MonitorSource(MasterAddress(state_dir=state)))

    async def main_() -> None:
        async with app.run_test(size=(170, 45)) as pilot:
            await settle(app, pilot)
            await keys_and_checks(app, pilot)

    asyncio.run(main_())


def screen_text(app: MonitorApp) -> str:
    return "\n".join(str(app.query_one(f"#{w}").render()) for w in ("top", "grid", "detail"))


def log_text(app: MonitorApp) -> str:
    return "\n".join(line.text for line in app.query_one("#log").lines)


def test_the_screen_shows_the_slaves_and_program(board):
    async def check(app, pilot):
        text = screen_text(app)
        assert "normal operation" in text and "running" in text
        assert " 4 0000/0000" in text and "17 0000/0000" in text
        assert "PDA" in text

    run(board, check)


def test_arrows_select_and_input_keys_toggle_bits(board):
    async def check(app, pilot):
        await pilot.press("right", "right", "right")  # slave 1 -> 4
        assert app.selected == 4
        await pilot.press("0")
        await settle(app, pilot, 4)
        assert status(board)["slaves"]["17"]["outputs"] == 8, "I 4.0 -> Q 17.3"
        assert "slave 4" in screen_text(app) and "inputs  0001" in screen_text(app)
        await pilot.press("1", "2", "3")
        await settle(app, pilot)
        assert status(board)["slaves"]["4"]["inputs"] == 0b1111
        await pilot.press("0")
        await settle(app, pilot, 4)
        assert status(board)["slaves"]["17"]["outputs"] == 0
        await pilot.press("down")
        assert app.selected == 12
        await pilot.press("up", "left")
        assert app.selected == 3

    run(board, check)


def test_start_stop_and_outputs_while_stopped(board):
    async def check(app, pilot):
        await pilot.press("s")
        await settle(app, pilot)
        assert status(board)["start_flag"] is False
        app.selected = 17
        await pilot.press("o")
        await pilot.press(*"0b0101", "enter")
        await settle(app, pilot)
        assert status(board)["slaves"]["17"]["outputs"] == 0b0101
        await pilot.press("s")
        await settle(app, pilot)
        assert status(board)["control_state"] == "running"
        app.selected = 17
        await pilot.press("o", "1", "enter")
        await settle(app, pilot)
        assert "running and owns the outputs" in log_text(app)

    run(board, check)


def test_flag_byte_and_bit(board):
    async def check(app, pilot):
        await pilot.press("f", *"FY 10=0x12", "enter")  # both forms as the prompt shows them
        await settle(app, pilot)
        assert status(board)["flags"][10] == 0x12
        await pilot.press("f", *"F 10.0=1", "enter")
        await settle(app, pilot)
        assert status(board)["flags"][10] == 0x13
        await pilot.press("f", *"FY 999=1", "enter")
        await settle(app, pilot)
        assert "'FY 999': flag byte 0..127" in log_text(app), "a bad entry is reported, not fatal"

    run(board, check)


def test_plug_unplug_address_and_stores(board):
    async def check(app, pilot):
        app.selected = 9
        await pilot.press("p", *"iiio,1", "enter")
        await settle(app, pilot, 4)
        assert "9" in status(board)["slaves"]
        await pilot.press("m")  # protected -> configuration
        await settle(app, pilot)
        assert status(board)["mode"] == "configuration"
        await pilot.press("a", *"12", "enter")
        await settle(app, pilot, 4)
        cable = json.loads(cli(board, "bus", "show", "--json"))
        assert 12 in [s["address"] for s in cable["slaves"]]
        assert 9 not in [s["address"] for s in cable["slaves"]]
        await pilot.press("f6")
        await settle(app, pilot, 4)
        assert 12 in status(board)["lps"]
        await pilot.press("f5")
        await settle(app, pilot)
        assert "F5 store actual parameters: done" in log_text(app)
        app.selected = 12
        await pilot.press("u")
        await settle(app, pilot, 4)
        cable = json.loads(cli(board, "bus", "show", "--json"))
        assert 12 not in [s["address"] for s in cable["slaves"]]
        await pilot.press("m")
        await settle(app, pilot)
        assert status(board)["mode"] == "protected"

    run(board, check)


def test_address_change_refusal_is_logged_with_its_code(board):
    async def check(app, pilot):
        app.selected = 20
        await pilot.press("a", *"21", "enter")
        await settle(app, pilot)
        assert "83A1" in log_text(app)

    run(board, check)


def test_set_button_reload_escape_and_quit(board):
    async def check(app, pilot):
        await pilot.press("b")
        await settle(app, pilot)
        assert "set button pressed" in log_text(app)
        await pilot.press("f9")
        await settle(app, pilot)
        assert "F9" in log_text(app)
        await pilot.press("o", "escape")
        assert app.focused is None, "escape closes the prompt"
        await pilot.press("q")
        await pilot.pause()
        assert app.return_code == 0 or not app.is_running

    run(board, check)


def test_events_are_logged(board):
    async def check(app, pilot):
        cli(board, "bus", "unplug", "4")
        await settle(app, pilot, 4)
        assert "configuration error: 4 missing" in log_text(app)
        assert "slaves lost: 4" in log_text(app)

    run(board, check)


def test_a_vanished_master_is_shown_and_found_again(tmp_path):
    state = tmp_path / "state"
    app = MonitorApp(MonitorSource(MasterAddress(io="devport", port="300h", state_dir=state)))

    async def main_() -> None:
        async with app.run_test(size=(170, 45)) as pilot:
            await settle(app, pilot)
            assert "master gone" in str(app.query_one("#top").render())
            assert "master gone" in log_text(app)

    asyncio.run(main_())
