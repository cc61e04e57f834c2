"""The monitor on a board that ``asictl gateway serve`` serves: the gateway's front panel on
the screen, and its keys, which press the served gateway's mode and set keys."""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from monitor_harness import cli, settle
from served_gateway import serve_gateway

from asictl.host.connection import MasterAddress
from asictl.monitor.app import MonitorApp
from asictl.monitor.source import MonitorSource


@pytest.fixture
def gateway(tmp_path: Path) -> Iterator[Path]:
    state = tmp_path / "state"
    with serve_gateway(state):
        cli(state, "bus", "plug", "4", "iiii,0")
        deadline = time.monotonic() + 10
        while json.loads(cli(state, "gateway", "panel", "--json"))["display"]["code"] == 88:
            assert time.monotonic() < deadline, "the display test lasts a second"
            time.sleep(0.1)
        yield state


def right(app: MonitorApp) -> str:
    return str(app.query_one("#right").render())


def mode(state: Path) -> str:
    return json.loads(cli(state, "status", "--json"))["mode"]


def test_the_panel_and_its_keys(gateway: Path):
    app = MonitorApp(MonitorSource(MasterAddress(state_dir=gateway)))

    async def main_() -> None:
        async with app.run_test(size=(170, 45)) as pilot:
            await settle(app, pilot)
            text = right(app)
            assert "gateway panel     04   slave 4 is detected" in text
            assert "● power" in text and "● prj mode" in text and "○ ser active" in text
            assert app.check_action("key", ("mode", 0.2)), "the keys are offered"
            await pilot.press("left_square_bracket")  # mode, short: protected mode
            await settle(app, pilot)
            await pilot.pause(0.4)  # the key comes up after 0.2 s
            await settle(app, pilot)
            assert mode(gateway) == "protected"
            assert "○ prj mode" in right(app)
            await pilot.press("left_curly_bracket")  # mode held 6 s
            start = time.monotonic()
            await settle(app, pilot)
            assert mode(gateway) == "protected", "not yet: a long press acts at 5 s"
            while "● prj mode" not in right(app):
                assert time.monotonic() - start < 15
                await pilot.pause(0.2)
                await settle(app, pilot, 1)
            assert 4.9 <= time.monotonic() - start < 6.5, "lit while the key is still held"
            assert mode(gateway) == "configuration"
            log = "\n".join(line.text for line in app.query_one("#log").lines)
            assert "mode key held 6 s: display" in log

    asyncio.run(main_())


def test_no_keys_without_a_gateway(tmp_path: Path):
    from monitor_harness import live

    with live(tmp_path, "[PROGRAM]\n        BE\n[END]\n") as state:
        app = MonitorApp(MonitorSource(MasterAddress(state_dir=state)))

        async def main_() -> None:
            async with app.run_test(size=(170, 45)) as pilot:
                await settle(app, pilot)
                assert not app.check_action("key", ("mode", 0.2))
                assert "gateway panel" not in right(app)
                before = mode(state)
                await pilot.press("left_square_bracket")
                await pilot.pause(0.4)
                await settle(app, pilot)
                assert mode(state) == before, "no gateway: the key does nothing"

        asyncio.run(main_())
