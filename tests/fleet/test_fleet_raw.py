"""Programs not in asictl's format in a fleet: a backup keeps them byte for byte, a restore
gives back the very bytes, through DPRAM and through the gateway, and ``fleet verify``
names exactly the master whose bytes changed, in a fleet that also runs asictl programs.

The oracle is the emulated board's EEPROM, read straight from its state file.
"""

from __future__ import annotations

import json
import random
import subprocess
from pathlib import Path

import pytest
from click.testing import CliRunner, Result
from intelhex import IntelHex
from served_gateway import serve_gateways

from asictl.cli import main
from asictl.host.emulated.boards import emulated_board
from asictl.host.raw_image import padded
from asictl.host.transfer import Pc2Transport
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.host.transports.jobs import JobError, JobStatus

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"


def asictl(*args: str, code: int = 0) -> Result:
    result = CliRunner().invoke(main, list(args))
    assert result.exit_code == code, (args, result.output)
    assert "Traceback" not in result.output
    return result


def acf_like(seed: int) -> bytes:
    """An image laid out as a vendor's might be: a jump at 0, a name, then code bytes."""
    rng = random.Random(seed)
    body = bytes(rng.randrange(256) for _ in range(2500))
    return bytes([0x02, 0x01, 0x00]) + b"ACF PROGRAM 1.0\0" + body


def state_with(state: Path, data: bytes) -> Path:
    state.mkdir(mode=0o700)
    with emulated_board(0x300, state) as board:
        Pc2Transport(Pc2Driver(EmulatedPort(board))).write_eeprom(0, data)
    return state


def eeprom(state: Path) -> bytes:
    with emulated_board(0x300, state) as board:
        return bytes(board._eeprom)


def test_a_mixed_fleet_backs_up_restores_and_finds_a_one_byte_change(tmp_path: Path):
    pc_raw = state_with(tmp_path / "pc-raw", acf_like(1))
    pc_ours = tmp_path / "pc-ours"
    pc_ours.mkdir(mode=0o700)
    asictl("download", str(BLINK), "--start", "--state-dir", str(pc_ours))
    gw_state = state_with(tmp_path / "gw-raw", acf_like(2))
    spare_pc = tmp_path / "spare-pc"
    spare_pc.mkdir(mode=0o700)
    spare_gw = state_with(tmp_path / "spare-gw", acf_like(3))
    with serve_gateways([gw_state, spare_gw]) as (gw, spare):
        inventory = tmp_path / "plant.toml"
        inventory.write_text(
            f'[masters.pc-raw]\nport = "300h"\nstate_dir = "{pc_raw}"\n\n'
            f'[masters.pc-ours]\nport = "300h"\nstate_dir = "{pc_ours}"\n\n'
            f'[masters.gw-raw]\nmodbus = "tcp://127.0.0.1:{gw}"\n'
        )
        archive = tmp_path / "archive"
        backup = json.loads(asictl("fleet", "backup", str(inventory), "--into", str(archive),
                                   "--format", "json").stdout)
        assert backup["failed"] == [] and len(backup["changed"]) == 3
        programs = {row["master"]: row["program"] for row in backup["masters"]}
        assert programs["pc-raw"].startswith("raw-") and programs["gw-raw"].startswith("raw-")
        assert not programs["pc-ours"].startswith("raw-")
        # the gateway holds its board: what it was given stands for its EEPROM
        for name, whole in (("pc-raw", eeprom(pc_raw)), ("gw-raw", padded(acf_like(2)))):
            archived = IntelHex(str(archive / name / "image.hex"))
            size = archived.maxaddr() + 1
            assert archived.minaddr() == 0 and size % 16 == 0
            assert bytes(archived.tobinarray()) == whole[:size]
            assert set(whole[size:]) == {0xFF}
        assert (archive / "pc-ours" / "blink.asi").exists()

        verified = json.loads(asictl("fleet", "verify", str(inventory), "--against",
                                     str(archive), "--format", "json").stdout)
        assert verified["drift"] == []
        glances = json.loads(asictl("fleet", "status", str(inventory), "--format",
                                    "json").stdout)["masters"]
        assert {g["master"]: g["program"] for g in glances} == {
            "pc-raw": "raw", "gw-raw": "raw", "pc-ours": programs["pc-ours"]}

        # restored to a second board, through DPRAM and through the gateway
        asictl("download", str(archive / "pc-raw" / "image.hex"), "--raw",
               "--state-dir", str(spare_pc))
        assert eeprom(spare_pc) == eeprom(pc_raw)
        asictl("verify", str(archive / "pc-raw" / "image.hex"), "--state-dir", str(spare_pc))
        url = f"tcp://127.0.0.1:{spare}"
        asictl("download", str(archive / "gw-raw" / "image.hex"), "--raw", "--modbus", url)
        asictl("verify", str(archive / "gw-raw" / "image.hex"), "--modbus", url)
        asictl("upload", "-o", str(tmp_path / "again.hex"), "--modbus", url)
        assert (tmp_path / "again.hex").read_bytes() == (
            archive / "gw-raw" / "image.hex").read_bytes()

        # one byte changed on the gateway's master: only it drifts
        changed = IntelHex(str(archive / "gw-raw" / "image.hex"))
        changed[0x200] = changed[0x200] ^ 0x40
        changed.write_hex_file(str(tmp_path / "changed.hex"), byte_count=16)
        asictl("download", str(tmp_path / "changed.hex"), "--raw", "--modbus",
               f"tcp://127.0.0.1:{gw}")
        drift = json.loads(asictl("fleet", "verify", str(inventory), "--against",
                                  str(archive), "--format", "json", code=1).stdout)
        assert drift["drift"] == ["gw-raw"]
        row = next(r for r in drift["masters"] if r["master"] == "gw-raw")
        assert row["differences"] == ["the EEPROM: 1 byte(s) differ, first at 0200h"]
        result = asictl("verify", str(archive / "gw-raw" / "image.hex"), "--modbus",
                        f"tcp://127.0.0.1:{gw}", code=1)
        assert "first at 0200h" in result.stdout
    assert eeprom(spare_gw) == padded(acf_like(2))


def backed_up(tmp_path: Path, seed: int) -> tuple[Path, Path, Path, bytes]:
    """A one-master plant with a raw program, backed up once: its state directory,
    inventory, archive and the archived image."""
    state = state_with(tmp_path / "pc", acf_like(seed))
    inventory = tmp_path / "plant.toml"
    inventory.write_text(f'[masters.pc]\nport = "300h"\nstate_dir = "{state}"\n')
    archive = tmp_path / "archive"
    asictl("fleet", "backup", str(inventory), "--into", str(archive))
    return state, inventory, archive, (archive / "pc" / "image.hex").read_bytes()


def test_a_failed_backup_keeps_the_previous_image(tmp_path: Path):
    state, inventory, archive, before = backed_up(tmp_path, 4)
    (state / "pc2-300h.json").write_text("{ not a board")  # the master cannot be read
    asictl("fleet", "backup", str(inventory), "--into", str(archive), code=1)
    assert (archive / "pc" / "image.hex").read_bytes() == before


def test_a_master_that_stops_answering_mid_backup_keeps_its_previous_image(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    state, inventory, archive, before = backed_up(tmp_path, 5)
    with emulated_board(0x300, state) as board:  # the program changes meanwhile
        Pc2Transport(Pc2Driver(EmulatedPort(board))).write_eeprom(0, acf_like(6))
    blocks = 0
    real = Pc2Transport.read_eeprom

    def stops_answering(self: Pc2Transport, address: int, size: int) -> bytes:
        nonlocal blocks
        blocks += 1
        if blocks > 10:  # somewhere inside the EEPROM
            raise JobError(JobStatus.INTERFACE_ERROR, "no answer from the board")
        return real(self, address, size)

    monkeypatch.setattr(Pc2Transport, "read_eeprom", stops_answering)
    result = asictl("fleet", "backup", str(inventory), "--into", str(archive), code=1)
    assert "no answer from the board" in result.output
    assert (archive / "pc" / "image.hex").read_bytes() == before
    assert git_clean(archive)


def git_clean(archive: Path) -> bool:
    status = subprocess.run(["git", "-C", str(archive), "status", "--porcelain"],
                            capture_output=True, text=True, check=True).stdout
    return status == ""
