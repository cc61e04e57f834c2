"""Whatever a command is given to read, it ends with a message, never a traceback or a hang.

Once, ``disasm`` and ``emu`` exited 3 on any non-UTF-8 byte, ``emu -`` looked for a file
named '-', a FIFO nobody wrote to hung ``check``, and /dev/zero filled the memory.
Inputs are now read with a bound (a source file 8 MB, a HEX file 2 MB), HEX files must be
ASCII, and a HEX file without an end record gets a warning.
"""

from __future__ import annotations

import json
import os
import threading
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from time_limit import no_hang

from asictl.cli import main
from asictl.errors import UserError
from asictl.mcs51.hexfile import MAX_HEX_BYTES, read_hex
from asictl.source import MAX_SOURCE_BYTES, read_bounded

PROGRAM = b":0300000002003BC0\n:00000001FF\n"


def test_a_binary_file_is_not_a_hex_file_exit_2(runner: CliRunner, tmp_path: Path):
    binary = tmp_path / "prog.bin"
    binary.write_bytes(bytes(range(256)) * 4)
    for command in (["disasm", str(binary)], ["emu", str(binary)]):
        result = runner.invoke(main, command)
        assert result.exit_code == 2, result.output
        assert "not a valid Intel HEX file: byte 80h on line 2 is not text" in result.stderr


@pytest.mark.parametrize("command", ["disasm", "emu"])
def test_a_hex_file_without_end_record_is_read_with_a_warning(runner, tmp_path, command):
    cut = tmp_path / "cut.hex"
    cut.write_bytes(PROGRAM.splitlines(keepends=True)[0])
    result = runner.invoke(main, [command, str(cut), "--max-instructions", "1"]
                           if command == "emu" else [command, str(cut)])
    assert result.exit_code == 0, result.output
    assert f"warning: {cut}: no end-of-file record" in result.stderr


def test_a_complete_hex_file_gets_no_warning(runner, tmp_path):
    whole = tmp_path / "whole.hex"
    whole.write_bytes(PROGRAM)
    result = runner.invoke(main, ["disasm", str(whole)])
    assert result.exit_code == 0 and result.stderr == ""
    assert "LJMP    003Bh" in result.stdout


def test_emu_dash_reads_standard_input(runner):
    result = runner.invoke(main, ["emu", "-", "--max-instructions", "1"], input=PROGRAM)
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["pc"] == 0x3B


@pytest.mark.parametrize(("command", "limit"), [
    (["check"], MAX_SOURCE_BYTES), (["asm", "-o", "x.hex"], MAX_SOURCE_BYTES),
    (["disasm"], MAX_HEX_BYTES), (["emu"], MAX_HEX_BYTES),
])
def test_dev_zero_is_refused_as_too_large(runner, command, limit):
    result = runner.invoke(main, [*command, "/dev/zero"])
    assert result.exit_code == 2, result.output
    assert f"/dev/zero: more than {limit // 2**20} MB" in result.stderr


def test_a_fifo_nobody_writes_to_does_not_hang(runner, tmp_path):
    fifo = tmp_path / "in.asi"
    os.mkfifo(fifo)
    with no_hang(20):
        result = runner.invoke(main, ["check", str(fifo)])
    assert result.exit_code in (0, 1, 2) and "internal error" not in result.output


def test_a_fifo_with_a_writer_is_read_to_its_end(tmp_path):
    fifo = tmp_path / "in.asi"
    os.mkfifo(fifo)
    text = b"[PROGRAM]\n  BE\n" * 10_000
    opened = threading.Event()

    def write() -> None:
        with open(fifo, "wb") as out:
            opened.set()
            out.write(text)

    # a reader that never reads lets the writer open at once (the FIFO's other end)
    idle_reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    writer = threading.Thread(target=write, daemon=True)
    writer.start()
    assert opened.wait(5)
    with no_hang(20):
        data = read_bounded(fifo, len(text) + 10, "a test file")
    writer.join(5)
    os.close(idle_reader)
    assert data == text


def test_a_directory_cannot_be_read_as_a_file(tmp_path):
    with pytest.raises(UserError, match="it is a directory"):
        read_bounded(tmp_path, 100, "a test file")


@given(st.integers(0, 3000), st.integers(0, 3000))
@settings(suppress_health_check=[HealthCheck.function_scoped_fixture], max_examples=50)
def test_read_bounded_refuses_exactly_what_exceeds_the_limit(tmp_path, size, limit):
    path = tmp_path / "f"
    path.write_bytes(b"x" * size)
    if size > limit:
        with pytest.raises(UserError, match="too large for a test file"):
            read_bounded(path, limit, "a test file")
    else:
        assert read_bounded(path, limit, "a test file") == b"x" * size


# ----- fuzz: any bytes as a HEX file ---------------------------------------------------

hex_like = st.lists(
    st.one_of(
        st.binary(max_size=40),
        st.from_regex(r":[0-9A-F]{0,50}", fullmatch=True).map(str.encode),
        st.sampled_from([b":00000001FF", b":0300000002003BC0", b":020000040001F9", b"\x1a"]),
    ),
    max_size=6,
).map(lambda lines: b"\n".join(lines))


@settings(max_examples=200, deadline=None)
@given(hex_like)
def test_any_bytes_as_a_hex_file_are_read_or_refused_plainly(data):
    runner = CliRunner()
    for command in (["disasm", "-"], ["emu", "-", "--max-instructions", "50"]):
        result = runner.invoke(main, command, input=data)
        assert result.exit_code in (0, 1, 2), (command, data, result.output)
        assert "internal error" not in result.output


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(hex_like)
def test_read_hex_raises_only_user_errors(data):
    import io
    import sys

    stdin = sys.stdin
    sys.stdin = io.TextIOWrapper(io.BytesIO(data))
    try:
        read_hex("-")
    except UserError:
        pass
    finally:
        sys.stdin = stdin
