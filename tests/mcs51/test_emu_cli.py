"""``asictl emu`` as a user sees it: options, JSON output, trace, messages, exit codes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from intelhex import IntelHex

from asictl.cli import main

# 0000: MOV R7,#3; L: INC A; DJNZ R7,L; MOV 30h,A; SJMP $
LOOP = bytes.fromhex("7f03 04 dffd f530 80fe")
END = 0x0007


def image(tmp_path: Path, program: bytes, at: int = 0) -> str:
    hex_file = IntelHex()
    hex_file.frombytes(program, offset=at)
    path = tmp_path / "prog.hex"
    hex_file.write_hex_file(str(path))
    return str(path)


def test_runs_until_and_prints_the_final_state(runner, tmp_path):
    result = runner.invoke(main, ["emu", image(tmp_path, LOOP), "--until", "7h"])
    assert result.exit_code == 0, result.output
    state = json.loads(result.stdout)
    assert state["pc"] == END and state["a"] == 3 and state["r7"] == 0
    assert state["iram"][0x30] == 3 and len(state["iram"]) == 256
    assert (state["instructions"], state["cycles"]) == (8, 11)
    assert state["sp"] == 7 and state["psw"] == 0 and state["stopped"] == "until address reached"
    assert set(state) >= {"b", "dptr", *(f"r{n}" for n in range(8))}


@pytest.mark.parametrize("address", ["0x2", "2h", "2", "02H"])
def test_start_accepts_hex_and_decimal_addresses(runner, tmp_path, address):
    program = bytes.fromhex("7405 04 80fe")  # MOV A,#5; INC A; SJMP $
    args = ["emu", image(tmp_path, program), "--start", address, "--until", "3"]
    result = runner.invoke(main, args)
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["a"] == 1  # MOV A,#5 skipped


def test_bad_address_is_a_usage_error(runner, tmp_path):
    result = runner.invoke(main, ["emu", image(tmp_path, LOOP), "--until", "12345h"])
    assert result.exit_code == 2
    assert "outside the 64 KB code space" in result.stderr
    result = runner.invoke(main, ["emu", image(tmp_path, LOOP), "--start", "zz"])
    assert result.exit_code == 2 and "is not an address" in result.stderr


def test_max_instructions_stops_the_run(runner, tmp_path):
    result = runner.invoke(main, ["emu", image(tmp_path, LOOP), "--max-instructions", "4"])
    assert result.exit_code == 0, result.output
    state = json.loads(result.stdout)
    assert state["instructions"] == 4 and state["a"] == 2 and state["pc"] == 0x0003
    assert state["stopped"] == "instruction budget exhausted"


def test_until_not_reached_is_a_failure_after_printing_the_state(runner, tmp_path):
    args = ["emu", image(tmp_path, LOOP), "--until", "0x100", "--max-instructions", "50"]
    result = runner.invoke(main, args)
    assert result.exit_code == 1
    assert json.loads(result.stdout)["instructions"] == 50
    assert "before reaching 0100h" in result.stderr


def test_trace_prints_each_instruction_to_stderr(runner, tmp_path):
    result = runner.invoke(main, ["emu", image(tmp_path, LOOP), "--until", "7", "--trace"])
    assert result.exit_code == 0, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 8
    assert lines[0].split()[:5] == ["0000", "7F", "03", "MOV", "R7,#03h"]
    assert "A=00" in lines[0] and "R0-R7=00 00 00 00 00 00 00 03" in lines[0]
    assert lines[1].startswith("0002  04") and "INC" in lines[1] and "A=01" in lines[1]
    assert "DJNZ" in lines[2] and "R7,0002h" in lines[2]
    assert json.loads(result.stdout)["a"] == 3  # stdout stays pure JSON


def test_undefined_opcode_fails_with_its_address(runner, tmp_path):
    result = runner.invoke(main, ["emu", image(tmp_path, bytes.fromhex("04 04 a5"))])
    assert result.exit_code == 1
    assert "undefined opcode A5h at 0002h" in result.stderr


def test_missing_or_malformed_file_is_exit_2(runner, tmp_path):
    result = runner.invoke(main, ["emu", str(tmp_path / "none.hex")])
    assert result.exit_code == 2 and "cannot read" in result.stderr
    bad = tmp_path / "bad.hex"
    bad.write_text(":zz\n")
    result = runner.invoke(main, ["emu", str(bad)])
    assert result.exit_code == 2 and "not a valid Intel HEX file" in result.stderr


def test_image_beyond_64k_is_refused(runner, tmp_path):
    result = runner.invoke(main, ["emu", image(tmp_path, b"\x00", at=0x10000)])
    assert result.exit_code == 2 and "beyond the 64 KB code space" in result.stderr


def test_program_loaded_at_its_hex_addresses(runner, tmp_path):
    program = bytes.fromhex("7442 80fe")  # MOV A,#42h; SJMP $
    path = image(tmp_path, program, at=0x0800)
    result = runner.invoke(main, ["emu", path, "--start", "0x800", "--until", "0x802"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["a"] == 0x42
