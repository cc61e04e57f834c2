"""``asictl probe``: a fixture of what a master tells, read-only, and its replay on the
emulated board.

Every fixture in probe_fixtures/ is replayed: its EEPROM is restored to a fresh emulated
board, which is probed again, and what a board reproduces whatever it runs (name, version
ID, capability letters, entry table, EEPROM) must agree. The one there now was recorded
from the emulated board; a fixture probed on a real board drops in beside it and then
shows where the emulator departs from the real firmware.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner, Result
from intelhex import IntelHex

from asictl.board import images
from asictl.board.board import Pc2Board
from asictl.cli import main
from asictl.gateway.server import background_gateway
from asictl.gateway.slave import GatewaySlave
from asictl.host.emulated.boards import emulated_board
from asictl.host.probe import CYCLE_KEY, SAMPLES, replay_differences
from asictl.host.transports.driver import Pc2Driver
from asictl.platform.pc2 import Command

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"
FIXTURES = sorted((Path(__file__).parent / "probe_fixtures").glob("*.json"))


def on(state: Path, *args: str) -> Result:
    result = CliRunner().invoke(main, [*args, "--state-dir", str(state)])
    assert "Traceback" not in result.output
    return result


def running_blink(state: Path) -> Path:
    assert on(state, "download", str(BLINK), "--start").exit_code == 0
    return state


def test_a_probe_writes_the_fixture_and_its_eeprom(tmp_path: Path):
    state = running_blink(tmp_path / "s")
    result = on(state, "probe", "-o", str(tmp_path / "p.json"))
    assert result.exit_code == 0, result.output
    fixture = json.loads((tmp_path / "p.json").read_text())
    assert fixture["identification"] == {
        "says": "AS-i PC2 Master / AS-i Control asictl emulation", "asictl_emulation": True}
    samples = fixture[CYCLE_KEY]
    assert len(samples) == SAMPLES and [s["after_ms"] for s in samples] == [
        0, 500, 1000, 1500, 2000]
    dpram = bytes.fromhex(fixture["dpram"])
    assert bytes.fromhex(samples[-1]["hex"]) == dpram[0x300:0x304]  # read last, unchanged
    assert samples[0]["previous_readings"]["ms_if_10ms"] == samples[0]["previous"] * 10
    with emulated_board(0x300, state) as board:
        stored = bytes(board._eeprom)
    hex_image = IntelHex(str(tmp_path / "p.hex"))
    assert bytes(hex_image.tobinarray()) == stored[: hex_image.maxaddr() + 1]
    verdicts = {v["assumption"].split(":")[0]: v["verdict"] for v in fixture["assumptions"]}
    assert verdicts["the firmware's entry table is read with command 53 from FF00h"] == "supports"
    assert verdicts["the firmware runs a program image in asictl's format"] == "supports"
    assert "supports     the firmware runs a program image" in result.stdout


def test_a_probe_only_reads(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    state = running_blink(tmp_path / "s")
    issued: list[int] = []
    real = Pc2Driver.command

    def recording(self: Pc2Driver, code: int, *args: int, **kw: float) -> int:
        issued.append(code)
        return real(self, code, *args, **kw)

    before = json.loads(on(state, "status", "--json").stdout)
    monkeypatch.setattr(Pc2Driver, "command", recording)
    assert on(state, "probe", "-o", str(tmp_path / "p.json")).exit_code == 0
    assert set(issued) == {Command.GET_STATUS, Command.UPLOAD, Command.READ_COMM_MEMORY}
    after = json.loads(on(state, "status", "--json").stdout)
    for key in ("lps", "control_flags", "program", "flags", "control_state"):
        assert after[key] == before[key], key


def test_a_look_alike_is_probed_without_an_override(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    monkeypatch.setattr(images, "MASTER_VERSION", b"V2.14".ljust(16, b"\0"))
    result = on(tmp_path / "s", "probe", "-o", str(tmp_path / "p.json"))
    assert result.exit_code == 0, result.output
    fixture = json.loads((tmp_path / "p.json").read_text())
    assert fixture["identification"]["asictl_emulation"] is False


def test_a_probe_through_the_gateway(tmp_path: Path):
    with background_gateway(GatewaySlave(Pc2Board())) as gateway:
        host, port = gateway.server.tcp_address
        result = CliRunner().invoke(main, ["probe", "-o", str(tmp_path / "g.json"),
                                           "--modbus", f"tcp://{host}:{port}"])
    assert result.exit_code == 0, result.output
    fixture = json.loads((tmp_path / "g.json").read_text())
    assert fixture["reached_through"] == "modbus" and fixture[CYCLE_KEY] is None
    assert bytes.fromhex(fixture["commands"]["17_report_slave_id"]).endswith(b"asictl emulation")
    assert "a gateway does not report the cycle times" in result.stdout


@pytest.mark.parametrize("fixture_path", FIXTURES, ids=[p.stem for p in FIXTURES])
def test_a_recorded_fixture_replays_on_the_emulated_board(fixture_path: Path, tmp_path: Path):
    recorded = json.loads(fixture_path.read_text())
    state = tmp_path / "s"
    hex_file = fixture_path.with_name(recorded["eeprom"]["file"])
    restored = on(state, "download", str(hex_file), "--raw")
    assert restored.exit_code == 0, restored.output
    assert on(state, "probe", "-o", str(tmp_path / "again.json")).exit_code == 0
    fresh = json.loads((tmp_path / "again.json").read_text())
    assert replay_differences(recorded, fresh) == []


def test_a_replay_names_what_the_emulator_does_differently(tmp_path: Path):
    recorded = json.loads(FIXTURES[0].read_text())
    other = json.loads(FIXTURES[0].read_text())
    other["status"]["version_id"] = "00000314"
    other["commands"]["entry_table_ff00h"] = {"refused": "83F9h"}
    found = replay_differences(other, recorded)
    assert [line.split(":")[0] for line in found] == ["version ID", "entry table (53 from FF00h)"]
    assert "'00000314'" in found[0]
