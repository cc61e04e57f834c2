"""[RAW] sections through the command line: what ``check`` flags is what ``compile``
refuses, and an image asictl did not write is refused saying so plainly."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner
from intelhex import IntelHex

from asictl.build import build_file
from asictl.cli import main
from asictl.codes import ImageCode
from asictl.host.emulated.boards import emulated_board
from asictl.host.program_files import uploaded_source
from asictl.image.eeprom import ProgramImage

ROOT = Path(__file__).resolve().parent.parent
NOT_OURS = "not a program image written by asictl"
ONLY_OURS = "asictl reads only the images it wrote itself"


@pytest.fixture
def uploaded() -> str:
    """What an upload writes for blink compiled without its source."""
    image = build_file(ROOT / "demos" / "blink.asi", with_source=False).image
    assert image is not None
    return uploaded_source(image)


def _hex_records(data: bytes) -> list[str]:
    hex_image = IntelHex()
    hex_image.frombytes(data, offset=0)
    lines: list[str] = []

    class Out:
        def write(self, text: str) -> None:
            lines.extend(text.splitlines())

    hex_image.write_hex_file(Out(), byte_count=16)
    return [line for line in lines if line]


def _replace_records(text: str, records: list[str]) -> str:
    lines = text.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith(":"))
    last = max(i for i, line in enumerate(lines) if line.startswith(":"))
    return "\n".join(lines[:first] + records + lines[last + 1:]) + "\n"


def _check_and_compile(tmp_path: Path, text: str) -> tuple[str, str]:
    path = tmp_path / "uploaded.asi"
    path.write_text(text)
    runner = CliRunner()
    checked = runner.invoke(main, ["check", str(path)])
    compiled = runner.invoke(main, ["compile", str(path), "-o", str(tmp_path / "out.hex")])
    assert checked.exit_code == 1, checked.output
    assert compiled.exit_code == 1, compiled.output
    assert not (tmp_path / "out.hex").exists()
    return checked.stderr, compiled.stderr


def _diagnostic(stderr: str) -> str:
    return next(line for line in stderr.splitlines() if f"[{ImageCode.RAW_INVALID}]" in line)


def test_check_flags_a_record_with_a_bad_checksum_as_compile_does(uploaded: str, tmp_path):
    lines = uploaded.splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith(":10"))
    lines[at] = lines[at][:-2] + ("00" if lines[at][-2:] != "00" else "01")
    checked, compiled = _check_and_compile(tmp_path, "\n".join(lines) + "\n")
    line = _diagnostic(checked)
    assert "checksum" in line.lower() and ": error: [RAW] section:" in line
    assert line == _diagnostic(compiled)


def test_check_flags_an_image_whose_crc_is_wrong(uploaded: str, tmp_path):
    records = [line for line in uploaded.splitlines() if line.startswith(":")]
    data = bytearray(ProgramImage.from_hex("\n".join(records) + "\n").to_bytes())
    data[-1] ^= 0x01  # the records are sound; the image's own CRC-32 is not
    checked, compiled = _check_and_compile(
        tmp_path, _replace_records(uploaded, _hex_records(bytes(data)))
    )
    assert "image corrupted: CRC-32 is" in _diagnostic(checked)
    assert _diagnostic(checked) == _diagnostic(compiled)


def test_an_image_another_tool_wrote_is_refused_plainly(uploaded: str, tmp_path):
    foreign = bytes([0x02, 0x40, 0x00]) + bytes(range(61))  # 8051 code: LJMP 4000h ...
    checked, _ = _check_and_compile(tmp_path, _replace_records(uploaded, _hex_records(foreign)))
    line = _diagnostic(checked)
    assert NOT_OURS in line and ONLY_OURS in line and "02 40 00 00" in line


def test_check_of_a_folder_flags_the_bad_raw_file(uploaded: str, tmp_path):
    (tmp_path / "ok.asi").write_text(uploaded)
    (tmp_path / "bad.asi").write_text(uploaded.replace(":10", ":11", 1))
    result = CliRunner().invoke(main, ["check", str(tmp_path)])
    assert result.exit_code == 1
    assert "bad.asi" in _diagnostic(result.stderr)
    assert "checked 2 files: 1 error" in result.stderr


def test_upload_of_a_program_another_tool_wrote_backs_it_up_raw(tmp_path: Path):
    with emulated_board(0x300, tmp_path) as board:  # as if the vendor's tools had loaded it
        board._eeprom[0:16] = bytes([0x02, 0x40, 0x00]) + bytes(range(13))
    result = CliRunner().invoke(
        main, ["upload", "-o", str(tmp_path / "x.asi"), "--state-dir", str(tmp_path)]
    )
    assert result.exit_code == 0
    assert "the master's program is not in asictl's format: uploaded the EEPROM byte for " in (
        result.stderr
    )
    assert (tmp_path / "x.hex").read_text().startswith(":1000000002400000010203")
