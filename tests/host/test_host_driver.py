"""The driver against a fake port device: DevPort on a file with a scripted board behind it."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from host_helpers import ScriptedBoard, WiredDevPort

from asictl.host.transports.driver import DevPort, EmulatedPort, Pc2Driver
from asictl.host.transports.jobs import JobError, JobStatus, PortError
from asictl.platform.pc2 import (
    ACK,
    ADDRESS,
    ADDRESS_EXT,
    COMMAND,
    DATA,
    NAK,
    PORT_DATA,
    PORT_INDEX,
    PORT_PAGE,
    PROGRAM_BUFFER,
    Command,
)

BASE = 0x320


@pytest.fixture
def port_file(tmp_path: Path) -> str:
    path = tmp_path / "port"
    path.write_bytes(bytes(64 * 1024))
    return str(path)


def wired(port_file: str, board: ScriptedBoard) -> Pc2Driver:
    return Pc2Driver(WiredDevPort(BASE, port_file, board))


@pytest.mark.parametrize(
    ("address", "size"),
    [
        (0x000, 1), (0x0F8, 16), (0x1F0, 4), (0x2F0, 0x20), (0x300, 0x100), (0x010, 0x3F0),
        (0, 0x400),
    ],
)
def test_block_writes_and_reads_cross_page_boundaries(port_file: str, address: int, size: int):
    board = ScriptedBoard()
    driver = wired(port_file, board)
    data = bytes((address + i * 7) & 0xFF for i in range(size))
    driver.write(address, data)
    assert board.dpram[address : address + size] == data
    assert bytes(board.dpram[:address]) == bytes(address), "nothing wrapped onto page 0"
    assert driver.read(address, size) == data


def test_the_registers_travel_through_the_file_at_base_plus_offset(port_file: str):
    board = ScriptedBoard()
    board.dpram[0x123] = 0xA5
    driver = wired(port_file, board)
    assert driver.read_byte(0x123) == 0xA5
    with open(port_file, "rb") as f:
        f.seek(BASE)
        assert f.read(3) == bytes([0xA5, 0x23, 0x01])


def test_blocks_outside_the_dpram_are_a_bug():
    with pytest.raises(ValueError):
        Pc2Driver(EmulatedPort(ScriptedBoard())).read(0x3FF, 2)


def test_command_parameters_and_result(port_file: str):
    seen = {}

    def download(board: ScriptedBoard) -> int:
        seen["params"] = bytes(board.dpram[DATA : ADDRESS_EXT + 1])
        seen["buffer"] = bytes(board.dpram[PROGRAM_BUFFER : PROGRAM_BUFFER + 3])
        board.dpram[DATA] = 0x42
        return ACK

    board = ScriptedBoard({Command.DOWNLOAD: download}, delay_ms=5)
    driver = wired(port_file, board)
    driver.write(PROGRAM_BUFFER, b"abc")
    assert driver.command(Command.DOWNLOAD, data=3, address=0xE0, ext=0x01) == 0x42
    assert seen == {"params": bytes([3, 0xE0, 0x01]), "buffer": b"abc"}
    assert board.now_ms == 5, "one millisecond of master time per poll"
    assert board.dpram[COMMAND] == ACK and ADDRESS == DATA + 1


def test_refusal_is_status_8384(port_file: str):
    driver = wired(port_file, ScriptedBoard({Command.SET_LPS: lambda b: NAK}))
    with pytest.raises(JobError) as caught:
        driver.command(Command.SET_LPS)
    assert caught.value.status is JobStatus.REFUSED
    assert "command 12 (set lps): refused by the master [STATUS 8384h]" in str(caught.value)
    assert caught.value.exit_code == 1


def test_time_out_after_200_ms_of_master_time(port_file: str):
    board = ScriptedBoard()
    driver = wired(port_file, board)
    with pytest.raises(JobError) as caught:
        driver.command(Command.GET_STATUS)
    assert caught.value.status is JobStatus.INTERFACE_ERROR
    assert "no acknowledge within 200 ms" in str(caught.value)
    assert board.now_ms == 200


def test_invalid_acknowledge(port_file: str):
    driver = wired(port_file, ScriptedBoard({Command.GET_STATUS: lambda b: 0x77}))
    with pytest.raises(JobError, match="invalid acknowledge 77h") as caught:
        driver.command(Command.GET_STATUS)
    assert caught.value.status is JobStatus.INTERFACE_ERROR


def test_emulated_port_polls_cost_master_time():
    board = ScriptedBoard({Command.GET_STATUS: lambda b: ACK}, delay_ms=3)
    driver = Pc2Driver(EmulatedPort(board))
    driver.read(0x000, COMMAND)
    driver.read(COMMAND + 1, 0x400 - COMMAND - 1)
    assert board.now_ms == 0, "only reads of the command byte cost time"
    driver.command(Command.GET_STATUS)
    assert board.now_ms == 3


def test_emulated_port_follows_the_page_wrap():
    """The port's own idea of the pointer wraps as the board's does (manual 7.2)."""
    board = ScriptedBoard()
    port = EmulatedPort(board)
    port.write(PORT_INDEX, 0xF1)
    port.write(PORT_PAGE, 0x01)
    for _ in range(15 + 0xF0):  # 1F1h..1FFh, then the wrap to 000h, up to 0EFh
        port.read(PORT_DATA)
    port.read(PORT_DATA)  # 0F0h on page 0 is not the command byte
    assert board.now_ms == 0
    port.write(PORT_INDEX, 0x00)
    port.write(PORT_PAGE, 0x01)
    for _ in range(0xF0):
        port.write(PORT_DATA, 0)
    port.read(PORT_DATA)  # 1F0h
    assert board.now_ms == 1


def test_devport_errors_are_clear(tmp_path: Path):
    with pytest.raises(PortError, match="not present; this system has no direct port access"):
        DevPort(0x300, str(tmp_path / "missing"))
    locked = tmp_path / "locked"
    locked.write_bytes(bytes(16))
    locked.chmod(0)
    if os.geteuid() != 0:
        with pytest.raises(PortError, match="permission denied; direct port access needs root"):
            DevPort(0x300, str(locked))


def test_devport_past_the_end_of_the_device(tmp_path: Path):
    short = tmp_path / "short"
    short.write_bytes(bytes(0x300))
    port = DevPort(0x300, str(short))
    with pytest.raises(PortError, match="cannot read: end of"):
        port.read(0)
    port.close()
