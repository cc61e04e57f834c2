"""Why the program does not run, over the gateway as over the PC2 port.

The gateway has no stop-reason register: the Modbus path derives the control state and
the reason from what it shows (the flags of register 1009, the ec-flags, the EEPROM), and
must come to what the PC2 port reads from the board itself (306h/307h), the oracle here.
Also: a download that leaves the program stopped says how to start it.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.board.asi import Slave
from asictl.board.board import Pc2Board
from asictl.build import build, build_file
from asictl.cli import main
from asictl.gateway.server import background_gateway
from asictl.gateway.slave import GatewaySlave
from asictl.host import modbus_master
from asictl.host.status import control_summary
from asictl.host.transfer import Pc2Transport, StartMode, download
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.host.transports.modbus import open_modbus
from asictl.host.transports.target import parse_target
from asictl.platform.master import ControlFlag
from asictl.source import from_string

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"  # [SETUP] slave 31
SETTLE_MS = 2000.0


def _driver(board: Pc2Board) -> Pc2Driver:
    return Pc2Driver(EmulatedPort(board))


def _load(board: Pc2Board, start: StartMode, text: str | None = None) -> None:
    transport = Pc2Transport(_driver(board))
    built = (build(from_string("p.asi", text), entry_points=transport.entry_points()) if text
             else build_file(BLINK, entry_points=transport.entry_points()))
    assert built.image is not None, built.render()
    download(transport, built.image, start=start)


def _cable(board: Pc2Board, *addresses: int) -> None:
    for n in addresses:
        board.bus.attach(Slave(n, io_code=0x8, id_code=0))


SITUATIONS: dict[str, Callable[[Pc2Board], None]] = {
    "no program": lambda board: None,
    "not started": lambda board: (_cable(board, 31), _load(board, StartMode.STOP)),
    "no slaves, so no normal operation": lambda board: _load(board, StartMode.START),
    "running": lambda board: (_cable(board, 31), _load(board, StartMode.START)),
    "configuration error": lambda board: (
        _cable(board, 30), _load(board, StartMode.START),
    ),
    "configuration error ignored": lambda board: (
        _cable(board, 30),
        _load(board, StartMode.START,
              "[OPTIONS]\nignore_config_errors: yes\n[SETUP]\n31: 8h, 0\n[PROGRAM]\n"
              "    A I 31.0\n    = Q 31.0\n"),
    ),
}


@pytest.mark.parametrize("situation", SITUATIONS)
def test_the_gateway_says_what_the_pc2_port_says(situation: str):
    board = Pc2Board()
    SITUATIONS[situation](board)
    board.advance(SETTLE_MS)
    expected = control_summary(_driver(board))
    with background_gateway(GatewaySlave(board)) as gateway:
        host, port = gateway.server.tcp_address
        with open_modbus(parse_target(f"tcp://{host}:{port}")) as transport:
            assert modbus_master.control_summary(transport) == expected
            status = modbus_master.read_status(transport)
    assert status.control_state in expected
    assert status.stop_reason is None or status.stop_reason in expected


def test_a_cycle_time_out_is_one_of_two_reasons_over_the_gateway():
    board = Pc2Board()
    _cable(board, 31)
    _load(board, StartMode.START, "[SETUP]\n31: 8h, 0\n[PROGRAM]\nloop:   JU  = loop\n")
    board.advance(SETTLE_MS)
    assert control_summary(_driver(board)) == "control program halted (p.asi:4: cycle timeout)"
    with background_gateway(GatewaySlave(board)) as gateway:
        host, port = gateway.server.tcp_address
        with open_modbus(parse_target(f"tcp://{host}:{port}")) as transport:
            assert modbus_master.control_summary(transport) == (
                "control program halted "
                "(a cycle time-out, a program fault or waiting for the set button)"
            )


# ------------------------------------------------------------------ download's message


def _download(tmp_path: Path, *options: str):
    return CliRunner().invoke(
        main, ["download", str(BLINK), "--state-dir", str(tmp_path), *options]
    )


def test_download_says_how_to_start_a_program_it_left_stopped(tmp_path: Path):
    result = _download(tmp_path)
    assert result.exit_code == 0, result.output
    assert "control program idle (not started)" in result.stderr
    note = result.stderr.splitlines()[-1]
    assert note.startswith("asictl: note: the start flag is off")
    assert "'asictl start'" in note and "--start" in note


@pytest.mark.parametrize("option", ["--start", "--stop"])
def test_no_note_when_the_user_chose(option: str, tmp_path: Path):
    result = _download(tmp_path, option)
    assert result.exit_code == 0, result.output
    assert "note: the start flag is off" not in result.stderr


def test_no_note_when_the_program_runs_already(tmp_path: Path):
    assert _download(tmp_path, "--start").exit_code == 0
    again = _download(tmp_path)  # --keep: the start flag stays on
    assert "control program running" in again.stderr
    assert "note:" not in again.stderr


def test_download_over_the_gateway_says_why_not_as_the_pc2_path(tmp_path: Path):
    board = Pc2Board()
    with background_gateway(GatewaySlave(board)) as gateway:
        host, port = gateway.server.tcp_address
        url = f"tcp://{host}:{port}"
        kept = CliRunner().invoke(main, ["download", str(BLINK), "--modbus", url])
        started = CliRunner().invoke(main, ["download", str(BLINK), "--modbus", url, "--start"])
    assert kept.exit_code == 0 and started.exit_code == 0, kept.output + started.output
    assert "control program idle (not started)" in kept.stderr
    assert "note: the start flag is off" in kept.stderr
    # nothing on the gateway's cable: the master stays in its detection phase
    assert "control program waiting (not normal operation)" in started.stderr
    assert board.control_flags & ControlFlag.START
