"""The monitor's layout at the terminal sizes it is used at, its help screen, and the
one key table (monitor.keys) the help, the bindings and the docs share."""

from __future__ import annotations

import asyncio
import io
import re
from pathlib import Path

import pytest
from monitor_harness import live, settle
from rich.console import Console

from asictl.host.connection import MasterAddress
from asictl.monitor.app import HelpScreen, MonitorApp, grid_form, layout_for
from asictl.monitor.keys import KEYS
from asictl.monitor.source import MonitorSource

ROOT = Path(__file__).resolve().parents[2]
PROGRAM = "[SETUP]\n31: oooo, 0\n\n[PROGRAM]\n  A   I 1.0\n  =   Q 31.0\n  BE\n[END]\n"


def run(tmp_path: Path, size: tuple[int, int], check) -> None:
    with live(tmp_path, PROGRAM) as state:
        app = MonitorApp(MonitorSource(MasterAddress(state_dir=state)))

        async def main_() -> None:
            async with app.run_test(size=size) as pilot:
                await settle(app, pilot)
                await check(app, pilot)

        asyncio.run(main_())


def shown(app: MonitorApp, widget: str) -> str:
    return str(app.query_one(f"#{widget}").render())


def rendered(widget, width: int) -> str:
    """What a widget's content looks like ``width`` columns wide."""
    console = Console(width=width, file=io.StringIO(), record=True)
    console.print(widget.content)
    return console.export_text()


def on_screen(app: MonitorApp, widget: str) -> bool:
    """The widget is displayed and lies wholly inside the terminal."""
    node = app.query_one(f"#{widget}")
    region, screen = node.region, app.screen.region
    return bool(node.display and region.height) and screen.contains_region(region)


@pytest.mark.parametrize(("size", "layout"), [
    ((80, 24), "narrow"), ((120, 40), "medium"), ((200, 60), "wide"), ((170, 45), "wide"),
])
def test_every_slave_is_on_the_screen_at_each_size(tmp_path, size, layout):
    async def check(app, pilot):
        assert app.layout_name == layout and layout in app.screen.classes
        grid = shown(app, "grid")
        found = [int(n) for n in re.findall(r"(\d+) (?:----|[01]{4})/", grid)]
        assert found == list(range(32)), grid
        assert on_screen(app, "grid") and on_screen(app, "detail")
        assert app.query_one("#grid").region.height == grid.count("\n") + 1, "nothing cut"
        assert max(map(len, grid.splitlines())) <= app.query_one("#grid").content_size.width
        assert "31 0000/0000" in grid
        panel = {"wide": "right", "medium": "under"}.get(layout)
        if panel is None:  # the panel does not fit: the data view shows it
            assert not app.query_one("#right").display and not app.query_one("#under").display
            await pilot.press("d")
            await settle(app, pilot)
            panel = "data"
        assert on_screen(app, panel) and "F112" in shown(app, panel)
        assert "flag bytes F0..F127" in shown(app, panel)

    run(tmp_path, size, check)


def test_up_and_down_move_by_the_grid_row(tmp_path):
    async def check(app, pilot):
        assert app.columns == 4
        await pilot.press("down")
        assert app.selected == 5
        await pilot.press("up", "up")
        assert app.selected == 29, "wraps around"

    run(tmp_path, (80, 24), check)


def test_the_grid_forms_by_width():
    assert grid_form(158) == (8, True)
    assert grid_form(157) == (8, False)
    assert grid_form(103) == (8, False)
    assert grid_form(102) == (4, True)
    assert grid_form(78) == (4, True)
    assert grid_form(77) == (4, False)
    assert layout_for(80, 24) == "narrow" and layout_for(169, 60) == "medium"
    assert layout_for(200, 29) == "narrow", "too short for the panel beside"


@pytest.mark.parametrize("key", ["question_mark", "f1"])
def test_question_mark_and_f1_open_the_help_listing_every_key(tmp_path, key):
    async def check(app, pilot):
        await pilot.press(key)
        await pilot.pause()
        assert isinstance(app.screen, HelpScreen)
        text = rendered(app.screen.query_one("#help Static"), 76)
        for entry in KEYS:
            assert entry.label in text and entry.what[:30] in text.replace("\n", " ")
        await pilot.press("s")  # the monitor's keys do not act under the help
        await pilot.press("escape")
        await pilot.pause()
        assert not isinstance(app.screen, HelpScreen)
        await settle(app, pilot)
        assert app.status is not None and app.status.start_flag, "s did nothing"
        await pilot.press(key, "q")
        await pilot.pause()
        assert not isinstance(app.screen, HelpScreen) and app.is_running

    run(tmp_path, (80, 24), check)


def test_f10_quits(tmp_path):
    async def check(app, pilot):
        await pilot.press("f10")
        await pilot.pause()
        assert not app.is_running

    run(tmp_path, (80, 24), check)


def test_the_help_table_names_every_bound_key_and_no_other():
    bound = {binding.key for binding in MonitorApp.BINDINGS}  # type: ignore[union-attr]
    listed = {name for entry in KEYS for name in entry.bound}
    assert bound == listed


def test_the_docs_list_every_key():
    docs = (ROOT / "docs" / "commissioning.md").read_text()
    section = docs.split("## `asictl monitor`")[1].split("\n## ")[0]
    documented = [label.replace("\\|", "|") for label in re.findall(
        r"^\| `([^`]+)` \|", section, re.MULTILINE)]
    assert documented == [entry.label for entry in KEYS]
