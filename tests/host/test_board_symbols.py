"""Symbols on the board: ``download`` stores the program's symbol table in the image with
its source, ``upload`` writes it back beside the program, and the online commands take
and show its names."""

from __future__ import annotations

import json
import shutil
import tomllib
from pathlib import Path

import pytest
from live_helpers import ROOT, cli

from asictl.build import build_file
from asictl.observe.operands import image_symbols

TABLE = """\
# edge.asi's names
Signal = "I 1.0"
Edge   = "F10.0"   # written without the blank: the board reads it as F 10.0
Count  = "FY 11"
Lamp   = "Q 2.0"
"""


@pytest.fixture
def program(tmp_path: Path) -> Path:
    path = tmp_path / "edge.asi"
    shutil.copy(ROOT / "demos" / "edge.asi", path)
    (tmp_path / "edge.symbols.toml").write_text(TABLE)
    return path


def test_the_image_carries_the_table_and_the_program_reads_as_before(program):
    image = build_file(program).image
    assert image is not None
    assert image.symbols() == ("edge.symbols.toml", TABLE.encode())
    assert list(image.program_sources()) == ["edge.asi"]
    table = image_symbols(image)
    assert table.operand("edge") == "F 10.0" and table.name_of("Q 2.0") == "Lamp"
    assert build_file(ROOT / "demos" / "edge.asi").image.symbols() is None


def test_the_table_survives_download_and_upload(program, tmp_path):
    state = tmp_path / "state"
    assert cli(state, "download", str(program)).exit_code == 0
    back = tmp_path / "back" / "edge.asi"
    back.parent.mkdir()
    result = cli(state, "upload", "-o", str(back))
    assert result.exit_code == 0, result.output
    written = back.with_name("edge.symbols.toml")
    assert tomllib.loads(written.read_text()) == tomllib.loads(TABLE)
    assert written.read_bytes() == TABLE.encode()
    # downloaded again from where it was uploaded: the identical image
    assert cli(state, "verify", str(back)).exit_code == 0
    # an upload never replaces a table that differs, unless told to
    written.write_text('Other = "I 1.1"\n')
    refused = cli(state, "upload", "-o", str(back))
    assert refused.exit_code == 1 and "edge.symbols.toml" in refused.output
    assert written.read_text() == 'Other = "I 1.1"\n'
    assert cli(state, "upload", "-o", str(back), "--overwrite").exit_code == 0
    assert written.read_bytes() == TABLE.encode()


def test_an_upload_to_standard_output_leaves_the_table_out_and_says_so(program, tmp_path):
    state = tmp_path / "state"
    assert cli(state, "download", str(program)).exit_code == 0
    result = cli(state, "upload", "-o", "-")
    assert result.exit_code == 0, result.output
    assert result.stdout.encode() == program.read_bytes()
    assert "symbol table is written only beside a file" in result.stderr


def test_online_commands_take_and_show_the_boards_names(program, tmp_path):
    state = tmp_path / "state"
    assert cli(state, "download", str(program), "--start").exit_code == 0
    assert cli(state, "bus", "match").exit_code == 0
    written = cli(state, "write", "Count=7")  # lost when the command ends (no serve)
    assert written.exit_code == 0 and "wrote Count=7" in written.output, written.output
    assert cli(state, "bus", "inputs", "Signal=1").exit_code == 0
    forced = cli(state, "force", "Edge=0", "Lamp=1")
    assert forced.exit_code == 0, forced.output
    assert forced.stdout == "Q 2.0 (Lamp) = 1\nF 10.0 (Edge) = 0\n"
    status = json.loads(cli(state, "status", "--json").stdout)
    assert status["symbols"] == {"Signal": "I 1.0", "Edge": "F 10.0", "Count": "FY 11",
                                 "Lamp": "Q 2.0"}
    assert {"operand": "F 10.0", "value": 0, "symbol": "Edge"} in status["forced"]
    assert status["flags"][10] & 1 == 0  # forced against Signal = 1
    assert status["slaves"]["2"]["outputs"] & 1 == 1
    text = cli(state, "status").stdout
    assert "F 10.0 (Edge) = 0" in text
    assert "symbols  Signal (I 1.0) = 1, Edge (F 10.0) = 0, Count (FY 11) = " in text
    assert "Lamp (Q 2.0) = 1" in text
    assert cli(state, "unforce", "Edge", "Lamp").exit_code == 0
    unknown = cli(state, "write", "Motor=1")
    assert unknown.exit_code == 2 and "'Motor' is not an operand" in unknown.output
    assert "did you mean" not in unknown.output  # nothing in the table is like it


@pytest.mark.parametrize("command", [["write", "Lmap=1"], ["force", "Lmap=1"],
                                     ["watch", "Lmap", "--duration", "10ms"],
                                     ["bus", "inputs", "Lmap=1"], ["unforce", "Lmap"]])
def test_a_misspelt_name_is_told_the_closest_of_the_boards_names(program, tmp_path, command):
    state = tmp_path / "state"
    assert cli(state, "download", str(program)).exit_code == 0
    result = cli(state, *command)
    assert result.exit_code == 2, result.output
    assert "did you mean 'Lamp' (Q 2.0)?" in result.output, result.output


def test_a_name_without_a_table_on_the_board_says_so(tmp_path):
    state = tmp_path / "state"
    assert cli(state, "download", str(ROOT / "demos" / "edge.asi")).exit_code == 0
    result = cli(state, "write", "Edge=1")
    assert result.exit_code == 2
    assert "the program on the master has no symbol table" in result.output
