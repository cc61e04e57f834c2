"""``asictl download|upload|start|stop|reset|status`` as a user sees them."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from click.testing import CliRunner

from asictl.board.asi import Slave
from asictl.board.images import VERSION_ID
from asictl.cli import main
from asictl.host import connection
from asictl.host.emulated.boards import emulated_board

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"


def test_download_then_status(run):
    result = run("download", str(BLINK), "--start")
    assert result.exit_code == 0, result.output
    assert result.stdout == ""
    last = result.stderr.splitlines()[-1]
    assert last.startswith(f"300h: downloaded {BLINK} (")
    assert last.endswith("control program running")  # the [SETUP] slaves are cabled

    status = run("status", "--json")
    assert status.exit_code == 0
    fields = json.loads(status.stdout)
    assert fields["port"] == "300h"
    assert fields["start_flag"] is True and fields["control_active"] is True
    assert fields["lps"] == [31] and fields["missing"] == [] and fields["las"] == [31]
    assert fields["mode"] == "protected" and fields["config_ok"] is True
    assert fields["display"] == {"code": None, "text": "", "blinking": False, "meaning": "blank"}
    assert fields["panel"] == "derived" and fields["leds"] is None  # a PC2 board has none
    program = fields["program"]
    assert program["valid"] is True and program["source_included"] is True
    assert len(program["identity"]) == 32
    assert fields["control_state"] == "running"
    assert fields["installed_software"].startswith("C")
    assert {"ec_flags", "cycle_time_ms", "max_cycle_time_ms", "wrong_profile", "phase"} <= set(
        fields
    )

    text = run("status")
    assert text.exit_code == 0
    assert "LPS  ...............................X" in text.stdout
    assert "config   no errors" in text.stdout
    assert "display  blank (as a gateway shows this state)" in text.stdout
    assert program["identity"] in text.stdout


def test_status_shows_the_firmware_version_id(run):
    """The eight digits at 0F0h that the manual's board check looks for (10.3.3)."""
    fields = json.loads(run("status", "--json").stdout)
    assert fields["version_id"] == VERSION_ID.decode("ascii")
    assert len(fields["version_id"]) == 8 and fields["version_id"].isdigit()
    assert f"  {fields['version_id']}  at 300h" in run("status").stdout


def test_status_of_a_running_program_with_a_wrong_slave(run):
    with emulated_board(0x300, run.state_dir) as board:
        for address, io_code in ((1, 0x0), (2, 0x8), (3, 0x8), (7, 0x3)):
            board.bus.attach(Slave(address, io_code=io_code, id_code=0))
    assert run("download", str(ROOT / "demos" / "logic.asi"), "--start").exit_code == 0
    with emulated_board(0x300, run.state_dir) as board:
        board.advance(100)
    fields = json.loads(run("status", "--json").stdout)
    assert fields["unexpected"] == [7] and fields["missing"] == []
    assert fields["display"]["code"] == 7  # the gateway's display: the wrong slave
    assert fields["display"]["meaning"] == "slave 7 is wrongly configured"
    assert fields["config_ok"] is False and fields["stop_reason"] == "config error"
    with emulated_board(0x300, run.state_dir) as board:
        board.bus.remove(7)
        board.bus.slave(3).io_code = 0x7
        board.advance(100)
    fields = json.loads(run("status", "--json").stdout)
    assert fields["wrong_profile"] == [{"slave": 3, "projected": 0x08, "detected": 0x07}]


def test_a_program_with_errors_is_refused_with_its_diagnostics(run, tmp_path: Path):
    bad = tmp_path / "bad.asi"
    bad.write_text("[PROGRAM]\n    A   I 1.0\n    =   Q 99.0\n")
    result = run("download", str(bad))
    assert result.exit_code == 1
    assert f"{bad}:3:" in result.stderr and "error:" in result.stderr
    assert "=   Q 99.0" in result.stderr and "^" in result.stderr
    assert run("status", "--json").exit_code == 0
    assert json.loads(run("status", "--json").stdout)["program"]["present"] is False


def test_unreadable_input_and_bad_usage_exit_2(run, tmp_path: Path):
    assert run("download", str(tmp_path / "missing.asi")).exit_code == 2
    garbage = tmp_path / "x.hex"
    garbage.write_text(":00000001FF\n")
    assert run("download", str(garbage)).exit_code == 2
    assert run("status", "--port", "333h").exit_code == 2
    assert run("download", str(BLINK), "--io", "serial").exit_code == 2
    assert run("upload").exit_code == 2, "-o is required"


def test_devport_without_access_is_a_clear_error(run, monkeypatch, tmp_path: Path):
    original = connection.DevPort
    monkeypatch.setattr(
        connection, "DevPort", lambda base: original(base, str(tmp_path / "no-port"))
    )
    result = run("status", "--io", "devport")
    assert result.exit_code == 2
    assert "no-port: not present; this system has no direct port access" in result.stderr


def test_upload_does_not_overwrite_without_overwrite(run, tmp_path: Path):
    run("download", str(BLINK))
    target = tmp_path / "blink.asi"
    assert run("upload", "-o", str(target)).exit_code == 0
    assert target.read_bytes() == BLINK.read_bytes()
    assert run("upload", "-o", str(target)).exit_code == 0, "same content: nothing to do"
    target.write_text("mine\n")
    result = run("upload", "-o", str(target))
    assert result.exit_code == 1
    assert "exists with other content; not overwritten (use --overwrite)" in result.stderr
    assert target.read_text() == "mine\n"
    assert run("upload", "-o", str(target), "--overwrite").exit_code == 0
    assert target.read_bytes() == BLINK.read_bytes()


def test_upload_with_function_blocks_keeps_a_changed_block_file(run, tmp_path: Path):
    for name in ("fb.asi", "latch.fb", "count3.fb"):
        shutil.copy(ROOT / "demos" / name, tmp_path)
    assert run("download", str(tmp_path / "fb.asi")).exit_code == 0
    out = tmp_path / "out"
    out.mkdir()
    (out / "latch.fb").write_text("; my own latch\n")
    result = run("upload", "-o", str(out / "fb.asi"))
    assert result.exit_code == 1 and "latch.fb" in result.stderr
    assert not (out / "fb.asi").exists(), "nothing is written when a file is kept"
    assert run("upload", "-o", str(out / "fb.asi"), "--overwrite").exit_code == 0
    assert (out / "latch.fb").read_bytes() == (ROOT / "demos" / "latch.fb").read_bytes()


def test_upload_under_another_name_says_the_identity_changes(run, tmp_path: Path):
    run("download", str(BLINK))
    result = run("upload", "-o", str(tmp_path / "copy.asi"))
    assert result.exit_code == 0
    assert "main file was 'blink.asi'; compiled as 'copy.asi' it gets another identity" in (
        result.stderr
    )


def test_upload_of_an_empty_master_fails(run, tmp_path: Path):
    result = run("upload", "-o", str(tmp_path / "x.asi"))
    assert result.exit_code == 1
    assert "holds no program image [STATUS 83F9h]" in result.stderr
    assert not (tmp_path / "x.asi").exists()


def test_start_stop_reset(run):
    assert run("download", str(BLINK), "--stop").exit_code == 0
    result = run("start")
    assert result.exit_code == 0 and result.stderr.startswith("300h: control program")
    assert json.loads(run("status", "--json").stdout)["start_flag"] is True
    assert run("stop").exit_code == 0
    assert json.loads(run("status", "--json").stdout)["start_flag"] is False
    result = run("reset")
    assert result.exit_code == 0, result.output
    assert json.loads(run("status", "--json").stdout)["program_status"] == "loaded"


def test_reset_without_a_program_fails(run):
    result = run("reset", "--port", "0x328")
    assert result.exit_code == 1
    assert "no valid program in its EEPROM" in result.stderr and "83F9h" in result.stderr


def test_download_of_a_compiled_image(run, tmp_path: Path):
    hex_file = tmp_path / "blink.hex"
    assert CliRunner().invoke(main, ["compile", str(BLINK), "-o", str(hex_file)]).exit_code == 0
    assert run("download", str(hex_file), "--port", "32Ch").exit_code == 0
    assert run("upload", "--port", "32ch", "-o", str(tmp_path / "b.asi")).exit_code == 0
    assert (tmp_path / "b.asi").read_bytes() == BLINK.read_bytes()


def test_help_names_the_acf_switches():
    result = CliRunner().invoke(main, ["download", "--help"])
    for switch in ("/d+", "/s+", "/s-", "/s0"):
        assert switch in result.output


LOOP = "[SETUP]\n31: 0h, 0\n[PROGRAM]\n    A I 31.0\nspin:\n    L KB 1\n    JU = spin\n"


def test_a_cycle_time_out_names_its_il_line_in_download_and_status(run, tmp_path: Path):
    program = tmp_path / "loop.asi"
    program.write_text(LOOP)
    result = run("download", str(program), "--start")
    assert result.exit_code == 0, result.output
    assert result.stderr.splitlines()[-1].endswith(
        "control program halted (loop.asi:7: cycle timeout)")
    status = run("status")
    assert "control  halted (loop.asi:7: cycle timeout)" in status.stdout
    fields = json.loads(run("status", "--json").stdout)
    assert (fields["stop_reason"], fields["stop_line"]) == ("cycle timeout", "loop.asi:7")
