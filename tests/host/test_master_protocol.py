"""``Master``, whichever way the master is reached, and the emulated-only capability:
present on an emulated board (loaded or live), absent on a real board and a gateway,
with the refusal the commands have always given there."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.board.board import Pc2Board
from asictl.cli import main
from asictl.errors import ExitCode, UserError
from asictl.gateway.server import background_gateway
from asictl.gateway.slave import GatewaySlave
from asictl.host.connection import MasterAddress, open_board
from asictl.host.emulated.actions import SETTLE_MS
from asictl.host.live.client import LiveActions
from asictl.host.live.server import background_live
from asictl.host.master import Master
from asictl.host.pc2_master import Pc2Master
from asictl.host.transports.driver import EmulatedPort, Pc2Driver

REFUSAL = "is not an emulated board: its AS-i cable cannot be changed from here"


def refuses_emulated_actions(master: Master) -> None:
    assert master.action is None
    with pytest.raises(UserError, match=REFUSAL) as refused:
        master.emulated("bus")
    assert refused.value.exit_code == ExitCode.FAILED
    assert str(refused.value).startswith(master.name)


def test_a_pc2_board_without_the_capability_is_seen_as_real_hardware():
    board = Pc2Board()
    master = Pc2Master.over(Pc2Driver(EmulatedPort(board)), "300h")
    refuses_emulated_actions(master)
    before = board.now_ms
    master.settle()
    assert board.now_ms == before, "a real board runs on by itself"
    status = master.status()
    assert status.lcs is None and status.timers is None, "no emulated-only view"


def test_a_board_loaded_from_its_state_file_runs_on_after_a_change_only():
    board = Pc2Board()
    master = Pc2Master.loaded(board, "300h")
    assert master.action is not None and master.action.live is None
    before = board.now_ms
    assert master.emulated("bus") == {"powered": True, "slaves": []}
    assert board.now_ms == before, "a view changes nothing"
    master.emulated("plug", address=5, io_code=7, id_code=0xF)
    assert board.now_ms == pytest.approx(before + SETTLE_MS)
    master.settle()
    assert board.now_ms == pytest.approx(before + 2 * SETTLE_MS)
    assert master.status().lcs is not None


def test_a_live_board_offers_the_capability_through_its_socket(tmp_path: Path):
    with background_live(0x300, tmp_path, identity={"command": "test"}), open_board(
        MasterAddress(state_dir=tmp_path)
    ) as master:
        assert isinstance(master.action, LiveActions)
        assert master.action.live is not None and master.action.live.startswith("test (pid")
        slave = master.emulated("plug", address=9, io_code=7, id_code=0xF)
        assert slave["address"] == 9
        assert [s["address"] for s in master.emulated("bus")["slaves"]] == [9]


def test_a_live_board_waits_after_a_change_of_the_cable_only(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
):
    """A cable change needs config_ok's delay before the command reports the master's
    state; an input or a force reaches the program in its next cycle, and the action's
    answer is the command's report: a one-shot command does not wait after it."""
    settled: list[str] = []
    monkeypatch.setattr(LiveActions, "settle", lambda self: settled.append("settled"))
    with background_live(0x300, tmp_path, identity={"command": "test"}), open_board(
        MasterAddress(state_dir=tmp_path)
    ) as master:
        master.emulated("plug", address=4, io_code=0, id_code=0xF)
        assert settled == ["settled"]
        assert master.emulated("inputs", changes=[[4, 1, 1]]) == {"4": 1}
        assert master.emulated("force", changes=[["flags", 10, 1, 1]]) == [["flags", 10, 1, 1]]
        assert master.emulated("unforce", all=True)["released"] == 1
        master.emulated("bus")
        assert settled == ["settled"]
        master.emulated("unplug", address=4)
        assert settled == ["settled", "settled"]


def test_a_gateway_has_no_dpram_and_no_emulated_actions():
    with background_gateway(GatewaySlave(Pc2Board())) as gateway:
        host, port = gateway.server.tcp_address
        url = f"tcp://{host}:{port}"
        with open_board(MasterAddress(modbus=url)) as master:
            assert master.name == f"{url} unit 1"
            assert master.driver is None and master.quick_status is None
            assert not master.created
            refuses_emulated_actions(master)
            master.settle()
            assert master.status().port == f"Modbus {url} unit 1"


def test_writing_flags_notes_a_board_that_runs_only_during_the_command(tmp_path: Path):
    def write(*more: str) -> str:
        result = CliRunner().invoke(
            main, ["write", "FY 10=0x12", "--state-dir", str(tmp_path), *more]
        )
        assert result.exit_code == 0, result.output
        return result.stderr

    assert "this emulated board runs only during a command" in write()
    with background_live(0x300, tmp_path, identity={"command": "test"}):
        assert "runs only during a command" not in write()
