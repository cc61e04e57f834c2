"""The monitor never shows a stale board: when the live server it watches goes away it
takes over serving the board, or, when another process holds the board, shows the master
as gone and refuses the keys that would act on it (issue 23, item 1)."""

from __future__ import annotations

import asyncio
import ctypes
import json
import os
import re
import shutil
import time
from contextlib import ExitStack
from pathlib import Path

from monitor_harness import cli, settle

from asictl.host.connection import MasterAddress
from asictl.host.emulated.boards import lock_file
from asictl.host.emulated.locking import exclusive
from asictl.host.live.protocol import socket_path
from asictl.host.live.server import background_live
from asictl.monitor.app import MonitorApp
from asictl.monitor.source import MonitorSource

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
#: The bar: the screen says so within this many seconds.
WITHIN_S = 2.0


def log_text(app: MonitorApp) -> str:
    """The event log, its lines wrapped or not."""
    return re.sub(r"\s+", " ", " ".join(line.text for line in app.query_one("#log").lines))


def top(app: MonitorApp) -> str:
    return re.sub(r"\s+", " ", str(app.query_one("#top").render()))


async def until(app: MonitorApp, pilot, predicate, seconds: float) -> float:
    """Refresh as the monitor does until ``predicate()``; the seconds it took."""
    start = time.monotonic()
    while not predicate():
        elapsed = time.monotonic() - start
        assert elapsed < seconds, f"not within {seconds} s:\n{top(app)}\n{log_text(app)}"
        await pilot.pause(0.05)
    return time.monotonic() - start


def exchange(one: Path, other: Path) -> None:
    """Swap two folders in one step (renameat2 with RENAME_EXCHANGE), so nobody ever
    finds either place empty."""
    libc = ctypes.CDLL(None, use_errno=True)
    at_fdcwd, rename_exchange = -100, 2
    if libc.renameat2(at_fdcwd, bytes(one), at_fdcwd, bytes(other), rename_exchange):
        errno = ctypes.get_errno()
        raise OSError(errno, os.strerror(errno), str(one), None, str(other))


def board(tmp_path: Path) -> Path:
    state = tmp_path / "state"
    (tmp_path / "p.asi").write_text(PROGRAM)
    cli(state, "download", str(tmp_path / "p.asi"), "--start")
    cli(state, "bus", "match")
    return state


def test_the_server_goes_away_and_the_monitor_takes_over(tmp_path):
    state = board(tmp_path)
    server = ExitStack()
    server.enter_context(background_live(0x300, state, identity={"command": "asictl serve"}))
    source = MonitorSource(MasterAddress(state_dir=state))
    app = MonitorApp(source)

    async def main_() -> None:
        async with app.run_test(size=(80, 24)) as pilot:
            await settle(app, pilot)
            assert app.served_by is not None and "asictl serve" in app.served_by
            assert "served by asictl serve" in top(app)
            server.close()  # the server stops: its socket and lock go
            took = await until(app, pilot, lambda: "took over" in top(app), WITHIN_S)
            assert "took over: asictl serve" in log_text(app)
            assert app.error is None and app.served_by == "this monitor"
            # the board runs live again: a key acts, the program answers at once
            app.selected = 4
            await pilot.press("0")
            await settle(app, pilot, 4)
            status = json.loads(cli(state, "status", "--json"))
            assert status["slaves"]["17"]["outputs"] == 8, "I 4.0 -> Q 17.3 on the live board"
            print(f"took over {took:.2f} s after the server stopped")

    try:
        asyncio.run(main_())
    finally:
        source.close()
        server.close()
    assert not socket_path(state, 0x300).exists(), "the monitor's server stopped with it"


def test_the_board_taken_by_another_process_is_gone_until_it_is_free(tmp_path):
    state = board(tmp_path)
    with MonitorSource(MasterAddress(state_dir=state)) as source:
        app = MonitorApp(source)

        async def main_() -> None:
            async with app.run_test(size=(120, 40)) as pilot:
                await settle(app, pilot)
                assert app.served_by == "this monitor", "nobody served it: the monitor does"
                assert "the monitor keeps it running while it runs" in log_text(app)
                assert "took over" not in top(app), "serving from the start is no take-over"
                with ExitStack() as other:
                    # another process puts a state folder of its own in place, the board
                    # taken in it (the live board's guard, looking every 0.2 s, would
                    # make an empty place again and take the board first)
                    fresh = tmp_path / "fresh"
                    fresh.mkdir(mode=0o700)
                    other.enter_context(exclusive(lock_file(fresh, 0x300), "board 300h"))
                    exchange(fresh, state)
                    shutil.rmtree(fresh)
                    gone = await until(app, pilot, lambda: "MASTER GONE" in top(app), WITHIN_S)
                    assert "master gone" in log_text(app)
                    # (a refresh under way as the server stops says only that it went away)
                    await until(app, pilot, lambda: "in use by" in top(app), WITHIN_S)
                    assert app.query_one("#middle").has_class("gone")
                    await pilot.press("s")
                    await pilot.press("0")
                    await pilot.press("f")
                    await pilot.pause(0.1)
                    log = log_text(app)
                    assert "start/stop: refused, the master is gone" in log
                    assert "input bit: refused" in log and "flag: refused" in log
                    assert not app.query_one("#prompt").has_class("visible")
                # the board is free again: the monitor takes it over
                took = await until(app, pilot, lambda: "took over" in top(app), WITHIN_S)
                assert app.error is None and not app.query_one("#middle").has_class("gone")
                assert "master found again" in log_text(app)
                print(f"gone after {gone:.2f} s, taken over {took:.2f} s after it was free")

        asyncio.run(main_())
    assert not socket_path(state, 0x300).exists()
