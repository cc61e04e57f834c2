"""Download and upload against the emulated board: round trips, verification, start/stop."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from manual_examples import EXAMPLES

from asictl.board.asi import Slave
from asictl.board.board import Pc2Board
from asictl.build import build_file, build_image
from asictl.codegen8051.compiler import compile_program
from asictl.host.program_files import uploaded_files, write_files
from asictl.host.transfer import (
    Pc2Transport,
    StartMode,
    download,
    download_steps,
    linked_for,
    reset,
    set_start,
    upload,
)
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.host.transports.jobs import JobError, JobStatus
from asictl.il.checks import check_source
from asictl.image.eeprom import ProgramImage
from asictl.platform.master import ControlFlag
from asictl.platform.pc2 import IDI, INSTALLED_SOFTWARE, ODI, ControlState, ProgramStatus
from asictl.source import read_source

ROOT = Path(__file__).resolve().parents[2]
DEMOS = sorted((ROOT / "demos").glob("*.asi"))


def transport_for(board: Pc2Board) -> Pc2Transport:
    return Pc2Transport(Pc2Driver(EmulatedPort(board)))


def prepared(path: Path, transport: Pc2Transport) -> ProgramImage:
    result = build_file(str(path), entry_points=transport.entry_points())
    assert result.image is not None, result.diagnostics
    return result.image


def round_trip(source: Path, tmp_path: Path) -> None:
    """compile -> download -> upload -> download the upload -> upload: all identical."""
    transport = transport_for(Pc2Board())
    image = prepared(source, transport)
    download(transport, image, start=StartMode.START)
    first = upload(transport)
    assert first.to_bytes() == image.to_bytes()

    out = tmp_path / "uploaded" / source.name
    out.parent.mkdir()
    write_files(uploaded_files(first, out), overwrite=False)
    for name, raw in image.sources().items():
        assert (out.parent / name).read_bytes() == raw
    if image.sources():
        assert out.read_bytes() == source.read_bytes()

    again = prepared(out, transport)
    download(transport, again, start=StartMode.START)
    assert upload(transport).to_bytes() == image.to_bytes()


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_round_trip_of_every_manual_example(name: str, tmp_path: Path):
    source = tmp_path / f"{name}.asi"
    source.write_text(EXAMPLES[name])
    round_trip(source, tmp_path)


@pytest.mark.parametrize("demo", DEMOS, ids=lambda p: p.stem)
def test_round_trip_of_every_demo(demo: Path, tmp_path: Path):
    for path in demo.parent.glob("*.fb"):
        shutil.copy(path, tmp_path)
    source = tmp_path / demo.name
    shutil.copy(demo, source)
    round_trip(source, tmp_path)


def test_progress_counts_every_block_written_and_read_back():
    transport = transport_for(Pc2Board())
    image = prepared(ROOT / "demos" / "fb.asi", transport)
    steps: list[int] = []
    download(transport, image, progress=steps.append)
    assert len(steps) == download_steps(len(image.to_bytes()), 240) == 1 + 2 * 7


def test_function_block_files_are_written_beside_the_main_file(tmp_path: Path):
    transport = transport_for(Pc2Board())
    download(transport, prepared(ROOT / "demos" / "fb.asi", transport))
    out = tmp_path / "fb.asi"
    written = write_files(uploaded_files(upload(transport), out), overwrite=False)
    assert sorted(p.name for p in written) == ["count3.fb", "fb.asi", "latch.fb"]
    for path in written:
        assert path.read_bytes() == (ROOT / "demos" / path.name).read_bytes()


def image_without_source(path: Path) -> ProgramImage:
    compiled = compile_program(check_source(read_source(path)).program)
    return build_image(compiled, with_source=False)


def test_round_trip_of_an_image_without_source(tmp_path: Path):
    """The [RAW] path: the uploaded file downloads the identical image again."""
    transport = transport_for(Pc2Board())
    image = image_without_source(ROOT / "demos" / "timer.asi")
    download(transport, image)
    out = tmp_path / "timer.asi"
    write_files(uploaded_files(upload(transport), out), overwrite=False)
    assert "[RAW]" in out.read_text()
    raw = build_file(str(out), entry_points=transport.entry_points())
    assert raw.image is not None and raw.compiled is None
    download(transport, raw.image)
    assert upload(transport).to_bytes() == image.to_bytes()
    second = tmp_path / "second" / "timer.asi"
    second.parent.mkdir()
    write_files(uploaded_files(upload(transport), second), overwrite=False)
    assert second.read_bytes() == out.read_bytes()


def test_a_hex_image_downloads_as_it_is(tmp_path: Path):
    transport = transport_for(Pc2Board())
    image = prepared(ROOT / "demos" / "blink.asi", transport)
    hex_file = tmp_path / "blink.hex"
    hex_file.write_text(image.to_hex())
    download(transport, prepared(hex_file, transport))
    assert upload(transport).to_bytes() == image.to_bytes()


def test_an_image_linked_for_other_firmware_is_refused():
    transport = transport_for(Pc2Board())
    image = prepared(ROOT / "demos" / "fb.asi", transport)
    table = transport.entry_points()
    assert image.entry_points, "fb.asi calls firmware blocks"
    name = next(iter(image.entry_points))
    with pytest.raises(Exception, match="linked for other firmware") as caught:
        linked_for(image, {**table, name: table[name] + 0x40})
    assert caught.value.exit_code == 1
    linked_for(image, table)


def test_the_master_table_is_read_from_ff00h():
    table = transport_for(Pc2Board()).entry_points()
    assert [*table][:: len(table) - 1] == ["setpp", "getid"] and len(table) == 16
    assert table["setpp"] == 0x0100 and table["getid"] == 0x013C


def test_start_stop_keep_and_the_image_flags(tmp_path: Path):
    board = Pc2Board()
    transport = transport_for(board)
    source = tmp_path / "options.asi"
    source.write_text(EXAMPLES["options"])  # ignore_config_errors: yes, auto_start: no
    image = prepared(source, transport)
    flags = download(transport, image, start=StartMode.START)
    assert flags & ControlFlag.START
    assert flags & ControlFlag.IGNORE_CONFIG_ERRORS and flags & ControlFlag.WAIT_FOR_SET_BUTTON
    assert not download(transport, image, start=StartMode.STOP) & ControlFlag.START
    assert not download(transport, image, start=StartMode.KEEP) & ControlFlag.START
    assert set_start(transport, start=True) & ControlFlag.START
    assert download(transport, image, start=StartMode.KEEP) & ControlFlag.START
    assert not set_start(transport, start=False) & ControlFlag.START
    assert board.control_flags & ControlFlag.WAIT_FOR_SET_BUTTON, "stop keeps the other flags"


def test_configuration_is_written(tmp_path: Path):
    board = Pc2Board()
    board.bus.attach(Slave(16, io_code=0x1, id_code=0x1))
    board.bus.attach(Slave(3, io_code=0xB, id_code=0x0))
    transport = transport_for(board)
    source = tmp_path / "setup.asi"
    source.write_text(EXAMPLES["setup"])  # 16: iiio, 1, Eh / 3: Bh, 0
    download(transport, prepared(source, transport))
    ec = board.execution
    assert ec.lps == 1 << 16 | 1 << 3
    assert ec.pcd[16] == 0x11 and ec.pcd[3] == 0x0B
    assert ec.pp[16] == 0xE and ec.pp[3] == 0xF
    assert board.mode == "protected"
    board.advance(50)
    assert board.bus.slave(16).parameter == 0xE, "sent through the PI image"
    assert board.bus.slave(3).parameter == 0xF


def test_protected_mode_refused_with_a_slave_zero(tmp_path: Path):
    board = Pc2Board()
    board.bus.attach(Slave(0, io_code=0, id_code=0))
    transport = transport_for(board)
    board.advance(50)
    with pytest.raises(JobError, match="slave with address 0 is present") as caught:
        download(transport, prepared(ROOT / "demos" / "blink.asi", transport))
    assert caught.value.status is JobStatus.SLAVE_ZERO


class ForgetfulTransport(Pc2Transport):
    """An EEPROM that loses one bit of every block at 300h."""

    def write_eeprom(self, address: int, data: bytes) -> None:
        if address <= 0x300 < address + len(data):
            data = bytearray(data)
            data[0x300 - address] ^= 0x10
        super().write_eeprom(address, bytes(data))


def test_a_read_back_difference_is_83f9_and_leaves_no_valid_image():
    board = Pc2Board()
    transport = ForgetfulTransport(Pc2Driver(EmulatedPort(board)))
    image = prepared(ROOT / "demos" / "fb.asi", transport)
    assert len(image.to_bytes()) > 0x300
    with pytest.raises(JobError, match="first difference at 0300h") as caught:
        download(transport, image)
    assert caught.value.status is JobStatus.EEPROM_ERROR
    with pytest.raises(JobError, match="no program image") as caught:
        upload(transport)
    assert caught.value.status is JobStatus.EEPROM_ERROR


def test_upload_and_reset_of_an_empty_master_are_83f9():
    transport = transport_for(Pc2Board())
    with pytest.raises(JobError, match=r"holds no program image \[STATUS 83F9h\]"):
        upload(transport)
    with pytest.raises(JobError, match="no valid program in its EEPROM") as caught:
        reset(transport)
    assert caught.value.exit_code == 1


def nibble_image(values: dict[int, int]) -> bytes:
    image = bytearray(16)
    for slave, value in values.items():
        image[slave // 2] |= value << 4 * (slave % 2)
    return bytes(image)


def test_after_download_start_the_program_runs(tmp_path: Path):
    """logic.asi: a 4-input module at 1, 4-output modules at 2 and 3 (Q 2.0 = a AND b ...)."""
    board = Pc2Board()
    for address, io_code in ((1, 0x0), (2, 0x8), (3, 0x8)):
        board.bus.attach(Slave(address, io_code=io_code, id_code=0))
    driver = Pc2Driver(EmulatedPort(board))
    transport = Pc2Transport(driver)
    download(transport, prepared(ROOT / "demos" / "logic.asi", transport), start=StartMode.START)
    for a, b in ((0, 0), (1, 0), (0, 1), (1, 1)):
        board.bus.set_inputs(1, a | b << 1)
        board.advance(50)
        assert transport.control_flags() & ControlFlag.CONTROL_ACTIVE
        assert driver.read(INSTALLED_SOFTWARE, 1) == b"C", "C: a control program runs"
        assert driver.read(IDI, 16) == nibble_image({1: a | b << 1})
        odi = bytes(~x & 0xFF for x in driver.read(ODI, 16))  # stored inverted
        q2 = (a & b) | (a | b) << 1 | (1 - (a & b)) << 2 | (1 - (a | b)) << 3
        q3 = (a ^ b) | (1 - a) << 1
        assert odi == nibble_image({2: q2, 3: q3})
        assert board.bus.outputs(2) == q2 and board.bus.outputs(3) == q3


def test_reset_reloads_and_stop_stops():
    board = Pc2Board()
    transport = transport_for(board)
    download(transport, prepared(ROOT / "demos" / "blink.asi", transport), start=StartMode.START)
    assert board.program_status is ProgramStatus.LOADED
    reset(transport)
    assert board.program_status is ProgramStatus.LOADED and board.control_flags & ControlFlag.START
    set_start(transport, start=False)
    assert board.control_state is ControlState.IDLE
