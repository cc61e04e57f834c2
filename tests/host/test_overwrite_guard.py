"""The overwrite guard: a command that changes a master refuses one that is not asictl's
emulation unless told otherwise, and emulation is known only by what it says itself.

The look-alikes here are asictl's own emulation with its self-identification taken away
(a board whose version string is another, a pymodbus gateway whose function 17 answers
something else): everything else about them is the emulation, so only the
identification can be what the guard goes by.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner, Result
from gateway_stub import stub_gateway

from asictl.board import images
from asictl.board.board import Pc2Board
from asictl.cli import main
from asictl.gateway.server import background_gateway
from asictl.gateway.slave import SERVER_ID, GatewaySlave
from asictl.host.emulated.boards import emulated_board
from asictl.host.raw_image import to_hex
from asictl.host.transfer import Pc2Transport
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.host.transports.modbus import open_modbus
from asictl.host.transports.target import parse_target

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"
VENDOR = bytes([0x02, 0x40, 0x00]) + bytes(range(200))


def invoke(*args: str) -> Result:
    result = CliRunner().invoke(main, list(args))
    assert "Traceback" not in result.output
    return result


@pytest.fixture
def look_alike(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A state directory whose board says it is a vendor's master (version 'V2.14'), with
    a vendor's program in its EEPROM."""
    monkeypatch.setattr(images, "MASTER_VERSION", b"V2.14".ljust(16, b"\0"))
    state = tmp_path / "state"
    with emulated_board(0x300, state) as board:
        Pc2Transport(Pc2Driver(EmulatedPort(board))).write_eeprom(0, VENDOR)
    return state


def eeprom(state: Path) -> bytes:
    with emulated_board(0x300, state) as board:
        return bytes(board._eeprom[: len(VENDOR)])


def test_a_download_to_a_look_alike_is_refused_without_both_flags(look_alike: Path):
    state = ("--state-dir", str(look_alike))
    refused = invoke("download", str(BLINK), *state)
    assert refused.exit_code == 1
    assert "not asictl's emulation (it identifies as 'AS-i PC2 Master / AS-i Control V2.14')" \
        in refused.stderr
    assert "a program not in asictl's format (it starts with 02 40 00 00)" in refused.stderr
    assert "'asictl upload -o backup.hex'" in refused.stderr
    assert "--real-master and --unconfirmed-format" in refused.stderr
    assert eeprom(look_alike) == VENDOR
    one = invoke("download", str(BLINK), "--real-master", *state)
    assert one.exit_code == 1 and "give --unconfirmed-format to go ahead" in one.stderr
    assert eeprom(look_alike) == VENDOR
    both = invoke("download", str(BLINK), "--real-master", "--unconfirmed-format", *state)
    assert both.exit_code == 0, both.output
    assert eeprom(look_alike) != VENDOR


def test_a_raw_restore_to_a_look_alike_needs_only_real_master(look_alike: Path, tmp_path):
    (tmp_path / "other.hex").write_text(to_hex(bytes([0x02, 0x41]) + bytes(30)))
    state = ("--state-dir", str(look_alike))
    refused = invoke("download", str(tmp_path / "other.hex"), "--raw", *state)
    assert refused.exit_code == 1 and "give --real-master to go ahead" in refused.stderr
    assert eeprom(look_alike) == VENDOR
    done = invoke("download", str(tmp_path / "other.hex"), "--raw", "--real-master", *state)
    assert done.exit_code == 0, done.output
    assert eeprom(look_alike)[:2] == bytes([0x02, 0x41])


@pytest.mark.parametrize(
    "command",
    [
        ["setup", str(BLINK)],
        ["store", "configuration"],
        ["write", "F 10.0=1"],
        ["slave", "address", "5", "6"],
        ["slave", "parameter", "5", "3"],
        ["slave", "command", "5", "1Ch"],
        ["mode", "configuration"],
        ["hiflags", "--offline"],
        ["diag", "--set-los", "3"],
        ["start"],
        ["stop"],
        ["reset"],
        ["reset", "--hardware"],
        ["emc", "5", "--for", "1s"],
    ],
)
def test_every_command_that_changes_a_look_alike_is_refused(look_alike: Path, command):
    refused = invoke(*command, "--state-dir", str(look_alike))
    assert refused.exit_code == 1
    assert "give --real-master to go ahead" in refused.stderr


def test_stopping_a_look_alike_takes_real_master(look_alike: Path):
    state = ("--state-dir", str(look_alike))
    refused = invoke("stop", *state)
    assert "refused to clear the start flag (the control program stops)" in refused.stderr
    stopped = invoke("stop", "--real-master", *state)
    assert stopped.exit_code == 0, stopped.output
    assert invoke("emc", "off", *state).exit_code == 0  # ending a test changes nothing back


def test_reading_a_look_alike_is_not_refused(look_alike: Path, tmp_path: Path):
    for command in (["status"], ["mode"], ["hiflags"], ["diag"]):
        result = invoke(*command, "--state-dir", str(look_alike))
        assert result.exit_code == 0, (command, result.output)
    result = invoke("upload", "-o", str(tmp_path / "b.hex"), "--state-dir", str(look_alike))
    assert result.exit_code == 0, result.output


def test_asictl_s_emulated_board_needs_no_flag(tmp_path: Path):
    result = invoke("download", str(BLINK), "--state-dir", str(tmp_path / "s"))
    assert result.exit_code == 0, result.output


def test_the_emulated_gateway_says_what_it_is_in_function_17():
    with background_gateway(GatewaySlave(Pc2Board())) as gateway:
        host, port = gateway.server.tcp_address
        with open_modbus(parse_target(f"tcp://{host}:{port}")) as modbus:
            assert modbus.server_id() == SERVER_ID.encode()
            assert b"asictl emulation" in SERVER_ID.encode()
        result = invoke("download", str(BLINK), "--modbus", f"tcp://{host}:{port}")
        assert result.exit_code == 0, result.output


def test_a_gateway_whose_function_17_does_not_identify_is_real(tmp_path: Path):
    board = Pc2Board()
    with stub_gateway(board) as url:
        with open_modbus(parse_target(url)) as modbus:
            answer = modbus.server_id()  # pymodbus's own answer, not asictl's
            assert answer is not None and b"asictl emulation" not in answer
        refused = invoke("download", str(BLINK), "--modbus", url)
        assert refused.exit_code == 1
        assert "--real-master and --unconfirmed-format" in refused.stderr
        allowed = invoke("download", str(BLINK), "--modbus", url, "--real-master",
                         "--unconfirmed-format")
        assert allowed.exit_code == 0, allowed.output


def test_a_gateway_without_function_17_is_real():
    """As the VAG-MOD-KF-R4's manual has it: function 17 is not assigned."""
    slave = GatewaySlave(Pc2Board())
    del slave._functions[17]
    with background_gateway(slave) as gateway:
        host, port = gateway.server.tcp_address
        url = f"tcp://{host}:{port}"
        with open_modbus(parse_target(url)) as modbus:
            assert modbus.server_id() is None
        refused = invoke("setup", str(BLINK), "--modbus", url)
        assert refused.exit_code == 1
        assert "a gateway without function 17" in refused.stderr
