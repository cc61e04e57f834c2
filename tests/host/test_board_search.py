"""``--port auto``: the board search of AsiPc2Init(0) (PC2 manual 9.3, line 719), the manual's
CheckAsiPc2 (10.3.3) at 300h, 304h, ..., 32Ch in order, the first board found."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from host_helpers import ScriptedBoard, isa_bus

from asictl.board.board import Pc2Board
from asictl.host import connection, search
from asictl.host.emulated.boards import emulated_board
from asictl.host.live.server import background_live
from asictl.host.search import FOUND, NOT_FOUND, WRONG_FIRMWARE, check_board
from asictl.platform import pc2 as d


class Registers:
    """``PortIO`` straight onto a board's registers (no clock of its own)."""

    def __init__(self, board: Pc2Board | ScriptedBoard) -> None:
        self.board = board

    def read(self, offset: int) -> int:
        return self.board.io_read(offset)

    def write(self, offset: int, value: int) -> None:
        self.board.io_write(offset, value)

    def now_ms(self) -> float:
        return 0.0


def test_check_asi_pc2_wherever_index_and_page_point():
    board = Pc2Board()
    board.advance(10)
    for page, index in ((0, 0), (1, 0x80), (3, 0xFF)):
        board.io_write(d.PORT_PAGE, page)
        board.io_write(d.PORT_INDEX, index)
        assert check_board(Registers(board)) == FOUND


def test_a_wrong_version_and_no_name_are_not_a_board():
    scripted = ScriptedBoard()
    scripted.dpram[d.MASTER_NAME : d.MASTER_NAME + 8] = b"AS-i PC2"
    scripted.dpram[d.VERSION_ID : d.VERSION_ID + 8] = b"2.00 rev"
    assert check_board(Registers(scripted)) == WRONG_FIRMWARE
    assert check_board(Registers(ScriptedBoard())) == NOT_FOUND


def test_auto_finds_the_one_emulated_board_at_308h(run):
    assert run("status", "--port", "308h").exit_code == 0  # the board there now exists
    result = run("status", "--port", "auto", "--json")
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["port"] == "308h"
    assert "--port auto: found a PC2 board at 308h (none at 300h, 304h)" in result.stderr
    assert not (run.state_dir / "pc2-300h.json").exists(), "the search creates no boards"


def test_auto_takes_the_first_of_several_and_finds_a_live_one(run, tmp_path: Path):
    for port in ("32Ch", "320h"):
        assert run("status", "--port", port).exit_code == 0
    with background_live(0x30C, run.state_dir, identity={"command": "test"}):
        result = run("download", str(Path(__file__).parents[2] / "demos" / "blink.asi"),
                     "--port", "auto")
        assert result.exit_code == 0, result.output
        assert "found a PC2 board at 30Ch (none at 300h, 304h, 308h)" in result.stderr
    with emulated_board(0x30C, run.state_dir) as board:
        assert board.loaded_image is not None


def test_auto_without_a_board_says_so(run):
    result = run("status", "--port", "auto")
    assert result.exit_code == 1
    assert "--port auto: no PC2 board found at 300h, 304h, 308h, 30Ch, 320h, 324h, 328h, " \
        "32Ch (among the emulated boards in" in result.stderr


@pytest.fixture
def isa(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[int, Pc2Board]:
    """/dev/port with one board, at 308h; the test may change ``boards``."""
    board = Pc2Board()
    board.advance(100)
    installed = {0x308: board}
    bus = isa_bus(tmp_path / "port", installed)
    monkeypatch.setattr(search, "DevPort", bus)
    monkeypatch.setattr(connection, "DevPort", bus)
    return installed


def test_auto_finds_a_real_board_at_308h_through_dev_port(run, isa):
    result = run("status", "--io", "devport", "--port", "auto")
    assert result.exit_code == 0, result.output
    assert "found a PC2 board at 308h (none at 300h, 304h)" in result.stderr
    assert "AS-i PC2 Master / AS-i Control" in result.stdout and "at 308h" in result.stdout


def test_auto_through_dev_port_without_a_board(run, isa):
    isa.clear()
    result = run("status", "--io", "devport", "--port", "auto")
    assert result.exit_code == 1 and "(through /dev/port)" in result.stderr
