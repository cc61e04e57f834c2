"""``asictl emu`` and ``asictl disasm`` on an image from ``asictl compile``: its code at its
link address, not the header at 0 (which emu used to run as 100 M instructions of zeros)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner
from intelhex import IntelHex

from asictl.cli import main
from asictl.image.eeprom import ProgramImage
from asictl.runtime import layout
from asictl.runtime.program_map import CellKind

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def blink(tmp_path: Path) -> tuple[Path, ProgramImage]:
    path = tmp_path / "blink.hex"
    result = CliRunner().invoke(main, ["compile", str(ROOT / "demos" / "blink.asi"), "-o",
                                       str(path)])
    assert result.exit_code == 0, result.output
    return path, ProgramImage.from_hex(path.read_text())


def test_emu_runs_one_program_cycle_of_the_code(blink):
    path, image = blink
    result = CliRunner().invoke(main, ["emu", str(path)])
    assert result.exit_code == 0, result.output
    state = json.loads(result.stdout)
    assert state["stopped"] == "stopped by trap"  # the program's RET at the cycle end
    assert state["pc"] == layout.CYCLE_END
    assert 0 < state["instructions"] <= len(image.code)  # straight through, no loop
    # blink's first cycle: timer 0 is not running, so it is started and Q 31.0 inverted
    q30 = image.pmap.cells[CellKind.Q, 15]
    assert state["iram"][q30.address] >> 4 & 1 == 1, "Q 31.0 (slave 31 in the high nibble)"
    assert f"an asictl program image, identity {image.identity_hex}" in result.stderr
    assert "; ---- memory map" in result.stderr and "T 0" in result.stderr


def test_emu_start_and_until_still_apply(blink):
    path, image = blink
    end = image.code_base + len(image.code) - 1  # the final RET
    result = CliRunner().invoke(main, ["emu", str(path), "--until", f"{end:#x}"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["pc"] == end


def test_disasm_lists_the_code_at_its_link_address_after_the_map(blink, tmp_path: Path):
    path, image = blink
    result = CliRunner().invoke(main, ["disasm", str(path)])
    assert result.exit_code == 0, result.output
    text = result.stdout
    assert text.startswith(f"; {path}: an asictl program image, identity {image.identity_hex}")
    assert f"ORG     {image.code_base:04X}h" in text
    source = tmp_path / "code.a51"
    source.write_text(text)
    again = CliRunner().invoke(main, ["asm", str(source), "-o", str(tmp_path / "code.hex")])
    assert again.exit_code == 0, again.output
    code = IntelHex(str(tmp_path / "code.hex"))
    assert code.minaddr() == image.code_base
    assert code.tobinstr() == image.code


@pytest.mark.parametrize("command", ["emu", "disasm"])
def test_a_damaged_image_is_refused_not_run(command, blink, tmp_path: Path):
    _, image = blink
    data = bytearray(image.to_bytes())
    data[-1] ^= 0xFF  # the CRC no longer matches
    damaged = IntelHex()
    damaged.frombytes(bytes(data), offset=0)
    bad = tmp_path / "bad.hex"
    damaged.write_hex_file(str(bad))
    result = CliRunner().invoke(main, [command, str(bad)])
    assert result.exit_code == 2
    assert "starts like an asictl program image" in result.stderr
    assert "CRC" in result.stderr and "Traceback" not in result.output
