"""``asictl reset --hardware``: PAGE bit 4 held for the manual's 200 ms (PC2 manual 7.2, line
229), then the board's power-up (AsiPc2Reset, 9.3), on each kind of port."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from host_helpers import ScriptedBoard, isa_bus

from asictl.board.board import Pc2Board
from asictl.host import connection
from asictl.host.emulated.boards import emulated_board
from asictl.host.hardware_reset import RESET_HOLD_MS, hardware_reset
from asictl.host.live.server import background_live
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.host.transports.jobs import JobError, JobStatus
from asictl.platform import pc2 as d

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"


class Timed(EmulatedPort):
    """The emulated port, noting the master time of every PAGE write."""

    def __init__(self, board: Pc2Board) -> None:
        super().__init__(board)
        self.pages: list[tuple[float, int]] = []

    def write(self, offset: int, value: int) -> None:
        if offset == d.PORT_PAGE:
            self.pages.append((self.board.now_ms, value))
        super().write(offset, value)


def test_the_bit_is_held_200_ms_of_the_boards_time_and_the_board_powers_up():
    board = Pc2Board()
    board.advance(100)
    port = Timed(board)
    driver = Pc2Driver(port)
    driver.write(d.FLAGS, b"\x55")
    booted = board.power_up_ms
    powered = hardware_reset(driver, board.advance)
    resets = [(t, v) for t, v in port.pages if v & d.PAGE_RESET_BIT]
    (start, _), = resets
    release = next(t for t, v in port.pages if t > start and not v & d.PAGE_RESET_BIT)
    assert release - start == RESET_HOLD_MS == 200
    assert board.power_up_ms == release > booted, "the release is the power-up"
    assert driver.read(d.FLAGS, 1) == b"\x00", "the DPRAM is written anew (line 235)"
    assert powered.name == "AS-i PC2 Master / AS-i Control asictl emulation"
    assert powered.version_id == "00000200" and powered.held_ms == 200


def test_a_board_that_does_not_come_back_is_an_interface_error():
    scripted = ScriptedBoard()  # no name, no version ID: nothing a board check finds
    waited: list[float] = []

    class Port:
        def read(self, offset: int) -> int:
            return scripted.io_read(offset)

        def write(self, offset: int, value: int) -> None:
            scripted.io_write(offset, value)

        def now_ms(self) -> float:
            return sum(waited)

    with pytest.raises(JobError) as caught:
        hardware_reset(Pc2Driver(Port()), waited.append)
    assert caught.value.status is JobStatus.INTERFACE_ERROR
    assert "not found again within 2000 ms" in str(caught.value)
    assert waited[0] == 200 and 2000 <= sum(waited) - 200 <= 2010


def test_reset_hardware_on_an_emulated_board(run):
    assert run("download", str(BLINK), "--start").exit_code == 0
    result = run("reset", "--hardware")
    assert result.exit_code == 0, result.output
    first, last = result.stderr.splitlines()[-2:]
    assert first.startswith("300h: hardware reset: PAGE bit 4 held 200 ms; the board "
                            "powered up as AS-i PC2 Master / AS-i Control")
    assert "normal operation" in first and "protected mode" in first
    assert last == "300h: control program running"


def test_reset_hardware_on_a_live_board_loses_what_is_volatile(run):
    assert run("download", str(BLINK), "--start").exit_code == 0
    with background_live(0x300, run.state_dir, identity={"command": "test"}):
        assert run("write", "FY 5=0x42").exit_code == 0
        assert json.loads(run("status", "--json").stdout)["flags"][5] == 0x42
        result = run("reset", "--hardware")
        assert result.exit_code == 0, result.output
        assert "held 200 ms" in result.stderr
        status = json.loads(run("status", "--json").stdout)
        assert status["flags"][5] == 0 and status["control_state"] == "running"
    with emulated_board(0x300, run.state_dir) as board:
        assert board.loaded_image is not None, "the EEPROM keeps the program"


def test_reset_hardware_through_dev_port(run, tmp_path: Path, monkeypatch):
    board = Pc2Board()
    board.advance(100)
    monkeypatch.setattr(connection, "DevPort", isa_bus(tmp_path / "port", {0x300: board}))
    booted = board.power_up_ms
    result = run("reset", "--hardware", "--io", "devport")
    assert result.exit_code == 0, result.output
    assert board.power_up_ms > booted and "held 200 ms" in result.stderr


def test_a_gateway_has_no_hardware_reset(run):
    result = run("reset", "--hardware", "--modbus", "tcp://127.0.0.1:1")
    assert result.exit_code == 2 and "a gateway has none" in result.stderr
