"""The monitor's program view under Textual's harness, against a live emulated board.

``v`` swaps the slave view for the program's source with each line's values from the
latest cycle; the arrows and PgUp/PgDn scroll, ``n`` jumps to the next file. The values
come from the board the monitor watches (``observe.online``), so each test makes the board
do something and looks for it on the screen.
"""

from __future__ import annotations

import asyncio
import dataclasses
import re
from contextlib import contextmanager
from pathlib import Path

import pytest
from click.testing import CliRunner
from monitor_harness import cli, live, settle

from asictl.cli import main
from asictl.host import connection
from asictl.host.connection import MasterAddress
from asictl.host.listing import NO_SOURCE
from asictl.monitor import source as monitor_source
from asictl.monitor.app import MonitorApp
from asictl.monitor.source import NO_LINES_GATEWAY, NO_LINES_REAL, MonitorSource
from asictl.runtime.line_map import SourceLine

ROOT = Path(__file__).resolve().parents[2]
DEMOS = ROOT / "demos"
BLINKER = """\
[SETUP]
4: iiii, 0
17: oooo, 0

[PROGRAM]
        A   T 0             ; timer 0 running: keep the flag
        JC  = show
        N
        L   KT 200
        S   T 0
***
        AN  F 0.0           ; the flag blinks
        =   F 0.0
***
show:   A   F 0.0
        =   Q 17.0
***
        AN  I 4.0
        JC  = done
        A   F 0.0           ; only while I 4.0 is on
        =   Q 17.1
done:   BE
[END]
"""
LOOP = """\
[SETUP]
4: iiii, 0

[PROGRAM]
        A   I 4.0
        JC  = spin
        BE
spin:   A   I 4.1
        JU  = spin
[END]
"""


def run(state: Path, keys_and_checks, size: tuple[int, int] = (170, 45)) -> None:
    app = MonitorApp(MonitorSource(MasterAddress(state_dir=state)))

    async def main_() -> None:
        async with app.run_test(size=size) as pilot:
            await settle(app, pilot)
            await keys_and_checks(app, pilot)

    asyncio.run(main_())


def program_text(app: MonitorApp) -> str:
    return str(app.query_one("#program").render())


def row(app: MonitorApp, number: int) -> str:
    """The program view's row of line ``number`` (the first file that has it shown)."""
    for text in program_text(app).splitlines():
        if re.match(rf"(>>|  )\s*{number} ", text):
            return text
    raise AssertionError(f"line {number} not shown:\n{program_text(app)}")


def first_row(app: MonitorApp) -> str:
    """The first row under the column titles."""
    lines = program_text(app).splitlines()
    return lines[next(i for i, text in enumerate(lines) if "ACCU1" in text) + 1]


def values(text: str) -> list[str]:
    """RLO, ACCU1, ACCU2 (and the operand) at the end of a row (KREG left out)."""
    rlo, accu1, accu2, _kreg, operand = text.split()[-5:]
    return [rlo, accu1, accu2, operand]


def log_text(app: MonitorApp) -> str:
    return "\n".join(line.text for line in app.query_one("#log").lines)


def test_v_toggles_the_program_view_and_the_footer_says_so(tmp_path):
    async def check(app, pilot):
        bindings = app.screen.active_bindings
        assert bindings["v"].binding.description == "Program view"
        assert not app.source.watch_lines
        await pilot.press("v")
        await settle(app, pilot)
        assert app.view == "program" and app.source.watch_lines
        assert app.query_one("#program").display and not app.query_one("#slaves").display
        assert app.screen.active_bindings["v"].binding.description == "Slave view"
        assert "Next file" in [b.binding.description for b in app.screen.active_bindings.values()]
        text = program_text(app)
        assert "program view  blinker.asi" in text and "latest cycle at master time" in text
        assert "A   T 0             ; timer 0 running: keep the flag" in row(app, 6)
        await pilot.press("v")
        await settle(app, pilot)
        assert app.view == "slaves" and not app.source.watch_lines
        assert app.query_one("#slaves").display and not app.query_one("#program").display
        assert app.screen.active_bindings["v"].binding.description == "Program view"

    with live(tmp_path, BLINKER, "blinker.asi") as state:
        run(state, check)


def test_a_blinking_flag_shows_its_rlo_flip_between_refreshes(tmp_path):
    async def check(app, pilot):
        await pilot.press("v")
        seen_rlo, seen_operand = set(), set()
        for _ in range(60):
            await settle(app, pilot, 1)
            rlo, accu1, accu2, operand = values(row(app, 15))  # show: A F 0.0
            seen_rlo.add(rlo)
            seen_operand.add(operand)
            assert app.lines is not None
            assert app.lines.lines[SourceLine("blinker.asi", 15)].rlo == int(rlo)
            if len(seen_rlo) == 2:
                break
        assert seen_rlo == {"0", "1"}, seen_rlo
        assert seen_operand == {"0", "1"}
        assert (accu1, accu2) == ("0", "0") or int(accu1) >= 0

    with live(tmp_path, BLINKER, "blinker.asi") as state:
        run(state, check)


def test_lines_that_did_not_run_are_marked_and_run_after_an_input_key(tmp_path):
    async def check(app, pilot):
        await pilot.press("right", "right", "right")  # slave 1 -> 4, in the slave view
        await pilot.press("v")
        await settle(app, pilot)
        assert "not run" in row(app, 20) and "not run" in row(app, 21)
        assert "not run" not in row(app, 18)
        assert values(row(app, 18))[-1] == "0", "I 4.0 is 0"
        assert "slave 4: in 0000" in program_text(app)
        await pilot.press("right")  # no slave selection in the program view
        assert app.selected == 4
        await pilot.press("0")  # I 4.0 = 1
        await settle(app, pilot, 4)
        assert "not run" not in row(app, 20)
        assert values(row(app, 18))[-1] == "1"
        assert "slave 4: in 0001" in program_text(app)

    with live(tmp_path, BLINKER, "blinker.asi") as state:
        run(state, check)


def test_at_80x24_a_long_comment_header_opens_on_the_first_instruction(tmp_path):
    header = "".join(f"; header line {n}: what the program is for\n" for n in range(30))
    program = header + BLINKER

    async def check(app, pilot):
        await pilot.press("v")
        await settle(app, pilot)
        first = program.splitlines().index("        A   T 0             ; timer 0 running: keep "
                                           "the flag") + 1
        assert re.match(rf"(>>|  )\s*{first} +A   T 0", first_row(app)), program_text(app)
        await pilot.press("up")  # the rest is still there above it
        assert re.match(rf"\s*{first - 1} \[PROGRAM\]", first_row(app)), program_text(app)

    with live(tmp_path, program, "blinker.asi") as state:
        run(state, check, size=(80, 24))


def test_arrows_and_pages_scroll_and_n_goes_to_the_function_blocks(tmp_path):
    async def check(app, pilot):
        await pilot.press("v")
        await settle(app, pilot)
        rows = len(app.listing.lines)
        assert app.listing.files == ["fb.asi", "latch.fb", "count3.fb"]
        # its comment header is taller than the view: it opens on the first instruction
        assert re.match(r"\s+26 +A   I 1.0", first_row(app)), first_row(app)
        await pilot.press("pageup", "pageup", "pageup")
        assert first_row(app).startswith("── fb.asi")
        await pilot.press("down")
        assert app.program_top == 1 and re.match(r"\s+1 ; fb.asi", first_row(app))
        await pilot.press("up", "up")
        assert app.program_top == 0
        await pilot.press("pagedown")
        page = app.program_top
        assert page > 10, "a page is the rows shown, less one"
        assert re.match(rf"\s+{page} ", first_row(app))
        await pilot.press("pagedown", "pagedown", "pagedown", "pagedown")
        shown = len(program_text(app).splitlines()) - 2
        assert app.program_top == rows - shown, "the last page stays full"
        await pilot.press("pageup", "pageup", "pageup", "pageup", "pageup", "pageup")
        assert app.program_top == 0
        await pilot.press("n")
        await settle(app, pilot)
        assert first_row(app).startswith("── latch.fb")
        assert values(row(app, 9))[0] in ("0", "1"), "the block's lines have values"
        await pilot.press("n")
        await settle(app, pilot)
        assert "── count3.fb" in program_text(app)
        assert "not run" in row(app, 4), "Count3 runs only on an edge of I 1.2"
        await pilot.press("n")
        assert app.program_top == 0, "after the last file, the first again"

    with live(tmp_path, DEMOS / "fb.asi") as state:
        run(state, check, size=(170, 40))


def test_an_image_without_source_shows_line_numbers_values_and_a_note(tmp_path):
    (tmp_path / "p.asi").write_text(BLINKER)
    hex_file = tmp_path / "p.hex"
    result = CliRunner().invoke(main, ["compile", str(tmp_path / "p.asi"), "--no-source",
                                       "-o", str(hex_file)])
    assert result.exit_code == 0, result.output

    async def check(app, pilot):
        await pilot.press("v")
        await settle(app, pilot)
        text = program_text(app)
        assert NO_SOURCE[:40] in text.replace("\n", "")
        assert "A   T 0" not in text
        assert re.fullmatch(r"\s+15\s+[01]\s+0\s+0\s+\d+", row(app, 15)), "no operand"
        assert "not run" in row(app, 20)
        assert not any(re.match(r"\s+(5|11|14) ", line) for line in text.splitlines()), (
            "only lines with code"
        )

    with live(tmp_path, hex_file) as state:
        run(state, check)


@pytest.mark.parametrize(("shape", "note"), [("real", NO_LINES_REAL),
                                             ("gateway", NO_LINES_GATEWAY)])
def test_a_real_board_or_a_gateway_says_per_line_values_need_an_emulated_board(
    tmp_path, monkeypatch, shape, note
):
    """The master as a real PC2 (no emulated actions) or a gateway (no PC2 driver either)
    looks to the monitor: the source from the uploaded image, no values."""

    @contextmanager
    def as_hardware(address, notify=None, live_only=False):
        with connection.open_board(address, notify=notify, live_only=live_only) as master:
            if shape == "real":
                yield dataclasses.replace(master, action=None)
            else:
                yield dataclasses.replace(master, action=None, driver=None, quick_status=None)

    monkeypatch.setattr(monitor_source, "open_board", as_hardware)

    async def check(app, pilot):
        await pilot.press("v")
        await settle(app, pilot)
        text = program_text(app)
        assert note[:50] in text.replace("\n", "")
        assert "A   T 0             ; timer 0" in row(app, 6)
        assert "not run" not in text and "latest cycle" not in text
        assert app.lines is None

    with live(tmp_path, BLINKER, "blinker.asi") as state:
        run(state, check)


def test_a_cycle_time_out_names_its_line_on_top_in_the_log_and_in_the_view(tmp_path):
    async def check(app, pilot):
        await pilot.press("right", "right", "right", "0")  # I 4.0 = 1: into the loop
        await settle(app, pilot, 4)
        top = str(app.query_one("#top").render())
        assert "control program halted (loop.asi:9: cycle timeout)" in top
        assert "cycle 10 µs (max 10 µs)" in top  # not 0.0 ms
        assert "control program halted (loop.asi:9: cycle timeout)" in log_text(app)
        for _ in range(25):  # every refresh keeps the line (the image is kept, not re-read)
            await settle(app, pilot, 1)
            assert "loop.asi:9" in str(app.query_one("#top").render())
        await pilot.press("v")
        await settle(app, pilot)
        assert row(app, 9).startswith(">>")
        assert not row(app, 8).startswith(">>")
        assert "control program halted (loop.asi:9: cycle timeout)" in program_text(app)

    with live(tmp_path, LOOP, "loop.asi") as state:
        run(state, check)


def test_the_source_keeps_the_stop_line_between_image_reads(tmp_path):
    with live(tmp_path, LOOP, "loop.asi") as state:
        cli(state, "bus", "inputs", "I 4.0=1")
        source = MonitorSource(MasterAddress(state_dir=state))
        lines = [source.snapshot().status.stop_line for _ in range(3)]
    assert lines == ["loop.asi:9"] * 3


def test_x_shows_hex_and_the_constant_register_has_a_column(tmp_path):
    """L KC leaves both accumulators alone and loads the constant register (KREG): the
    view shows it in decimal and, after x, in hex."""
    program = (
        "[SETUP]\n4: iiii, 0\n17: oooo, 0\n\n[PROGRAM]\n        L   KC 300\n"
        "        A   I 4.0\n        =   Q 17.0\n        BE\n[END]\n"
    )

    async def check(app, pilot):
        await pilot.press("v")
        await settle(app, pilot)
        assert "KREG" in program_text(app) and "(hex)" not in program_text(app)
        _rlo, accu1, accu2, kreg = row(app, 6).split()[-4:]  # L KC 300: no operand
        assert (accu1, accu2, kreg) == ("0", "0", "300"), row(app, 6)
        assert values(row(app, 8))[-1] == "0"
        await pilot.press("x")
        await settle(app, pilot)
        assert "(hex)" in program_text(app)
        assert row(app, 6).split()[-3:] == ["0h", "0h", "12Ch"], row(app, 6)
        await pilot.press("x")
        await settle(app, pilot)
        assert "(hex)" not in program_text(app) and row(app, 6).split()[-1] == "300"

    with live(tmp_path, program, "kreg.asi") as state:
        run(state, check)


def test_a_comment_a_file_name_or_a_symbol_with_an_escape_sequence_shows_escaped():
    from asictl.host.listing import ListedLine, Listing
    from asictl.monitor.program import render_rows

    listing = Listing((ListedLine("p\x1b]0;x\x07.asi", 0, ""),
                       ListedLine("p.asi", 1, "A I 4.0 ; \x1b[2J\x9b", code=True)))
    shown = render_rows(listing, None, top=0, height=2, width=120).plain
    assert "\x1b" not in shown and "\x07" not in shown and "\x9b" not in shown
    assert "p\\x1b]0;x\\x07.asi" in shown and "; \\x1b[2J" in shown


def test_a_line_loading_a_timer_constant_shows_kreg_as_a_time_beside_its_ticks():
    from asictl.host.listing import ListedLine, Listing
    from asictl.monitor.program import render_rows
    from asictl.observe.online import CycleLines, LineValues

    listing = Listing((ListedLine("p.asi", 1, "L KT 2481", code=True),
                       ListedLine("p.asi", 2, "L KC 2481", code=True)))
    lines = CycleLines("id", "running", 0.0, "", {
        row.where: LineValues(row.where, 1, 1, 2481, 0, None, 2481) for row in listing.lines
    })
    timer, counter = render_rows(listing, lines, top=0, height=2, width=120).plain.splitlines()
    assert "2481" in timer and timer.endswith("KT 24.8 s")
    assert "2481" in counter and "KT" not in counter.split("L KC")[1]
