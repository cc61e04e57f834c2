"""A crafted image never bricks the board; a program that goes wrong only stops.

An image with a valid CRC but an inconsistent program map (a timer without its status
cell, a cell at internal RAM 300, a timer at XDATA FFFFh) was once accepted by download
and by the reset that loads it: setting the program up or its first 10 ms tick then
raised, and since every command powers the emulated board up from its state file, every
later command on that board exited 3 until the file was deleted. Now the image is held
to the runtime contract (``runtime.contract``) when it is read, a board whose EEPROM
holds a bad one powers up with program status "bad image" and stays usable, and whatever
a running program does wrong stops it with a reason instead of escaping ``advance``.

The property tests mutate the header and program map of every demo's image (with the
CRC fixed, so that the mutation reaches the checks behind it) and store it in a board as
any Modbus client could: the board refuses it or runs it, and always accepts the next
good download, which runs. With the code mutated too, the program may do anything a
program can (write into the DPRAM, fault, loop): the board still never fails, and after
a stop the next good download loads. ``-m slow`` runs them long.
"""

from __future__ import annotations

import dataclasses
import os
import struct

import pytest
from crafted_images import CRAFTED, CRC, DEMOS, demo_image, off_table, rich, with_crc
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from asictl.board.asi import AsiBus, Slave
from asictl.board.board import Pc2Board
from asictl.host.transfer import Pc2Transport, StartMode, download, set_start
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.host.transports.jobs import JobError, JobStatus
from asictl.image.eeprom import HEADER_SIZE, ImageError, ProgramImage
from asictl.platform import pc2 as d
from asictl.platform.master import ControlFlag
from asictl.platform.pc2 import ControlState, ProgramStatus, StopReason
from asictl.runtime.layout import default_entry_points
from asictl.runtime.program_map import CellKind

BLINK = next(path for path in DEMOS if path.name == "blink.asi")


def transport(board: Pc2Board) -> Pc2Transport:
    return Pc2Transport(Pc2Driver(EmulatedPort(board)))


def board_for(image: ProgramImage) -> Pc2Board:
    """A board whose cable holds the image's projected slaves, projected."""
    bus = AsiBus()
    for slave in image.configuration.slaves():
        bus.attach(Slave(slave.address, slave.io_code, slave.id_code))
    board = Pc2Board(bus=bus)
    transport(board).write_configuration(image.configuration)
    return board


def store_raw(board: Pc2Board, data: bytes) -> bool:
    """What any Modbus client can do (function 66, then register 1009): write the bytes
    into the EEPROM and reset with the start flag; False if the master refused the reset."""
    port = transport(board)
    port.write_eeprom(0, data)
    try:
        port.write_control_flags(ControlFlag.START | ControlFlag.RESET)
    except JobError as exc:
        assert exc.status is JobStatus.REFUSED
        return False
    return True


def assert_usable(board: Pc2Board, image: ProgramImage) -> None:
    """A good download is accepted, and its program loads and runs."""
    download(transport(board), image, start=StartMode.START)
    board.advance(300)
    assert board.program_status is ProgramStatus.LOADED, board.program_error
    assert board.loaded_image == image
    assert board.control_state is ControlState.RUNNING, board.stop_message


# ----------------------------------------------------------------------- the reproducers


@pytest.mark.parametrize("name", CRAFTED)
def test_a_crafted_image_is_refused_with_what_is_wrong(name: str):
    make, message = CRAFTED[name]
    with pytest.raises(ImageError, match="image breaks the runtime contract: ") as refused:
        ProgramImage.from_bytes(make())
    assert message in str(refused.value)


@pytest.mark.parametrize("name", CRAFTED)
def test_a_board_refuses_a_crafted_image_and_stays_usable(name: str):
    board = board_for(rich())
    assert not store_raw(board, CRAFTED[name][0]())
    board.advance(300)
    assert board.program_status is ProgramStatus.BAD_IMAGE
    assert board.program is None and board.stop_reason is StopReason.NO_PROGRAM
    assert CRAFTED[name][1] in board.program_error
    assert_usable(board, rich())


@pytest.mark.parametrize("name", CRAFTED)
def test_a_board_powers_up_with_a_crafted_image_as_bad_image(name: str):
    """The state file of a board holding such an image: every command powers it up."""
    board = board_for(rich())
    state = board.nonvolatile()
    state["eeprom"] = CRAFTED[name][0]().hex()
    state["control_flags"] = int(ControlFlag.START)
    again = Pc2Board.from_nonvolatile(state)
    again.advance(300)
    assert again.program_status is ProgramStatus.BAD_IMAGE
    assert_usable(again, rich())


def test_entry_points_off_this_firmwares_table_are_a_bad_image():
    assert ProgramImage.from_bytes(off_table()).entry_points == {"getlas": 0x0101}
    board = board_for(rich())
    assert not store_raw(board, off_table())
    assert board.program_status is ProgramStatus.BAD_IMAGE
    assert "GetLAS linked at 0101h; this master's firmware has it at 011Ch" in (
        board.program_error
    )
    assert_usable(board, rich())


def test_the_rich_program_runs_with_every_kind_of_map_entry():
    pmap = rich().pmap
    assert {kind for kind, _ in pmap.cells} == set(CellKind)
    assert pmap.timers.keys() == {6, 134} and pmap.counters.keys() == {27}
    assert pmap.variables.keys() == {"reading", "level"}
    assert_usable(board_for(rich()), rich())


# ----------------------------------------------------------------------- running faults


def _with_code(image: ProgramImage, code: bytes, **fields: object) -> ProgramImage:
    return dataclasses.replace(image, code=code, **fields)


def test_an_undefined_opcode_stops_the_program_with_a_reason():
    blink = demo_image(BLINK)
    faulty = _with_code(blink, bytes([0x00, 0xA5]) + blink.code[2:])
    board = board_for(blink)
    download(transport(board), faulty, start=StartMode.START)
    board.advance(300)
    assert board.control_state is ControlState.HALTED
    assert board.stop_reason is StopReason.PROGRAM_FAULT
    assert board.stop_message == (
        "program fault: undefined opcode A5h at 4001h; waiting for the set button or a "
        "new start"
    )
    assert board.outputs == bytes(16)
    assert board.dpram[d.STOP_ADDRESS : d.STOP_ADDRESS + 2] == b"\x01\x40"  # for the host
    board.press_set_button()
    board.advance(100)
    assert board.stop_reason is StopReason.PROGRAM_FAULT, "it faults again"
    assert_usable(board, blink)


def test_an_exception_in_a_tick_stops_the_program(monkeypatch: pytest.MonkeyPatch):
    """Whatever fails while a loaded program runs is a stop, never out of ``advance``."""
    blink = demo_image(BLINK)
    board = board_for(blink)
    assert_usable(board, blink)
    runner = board.program
    assert runner is not None

    def broken(ticks: int = 1) -> None:
        raise RuntimeError("broken tick")

    monkeypatch.setattr(runner, "tick", broken)
    board.advance(100)
    assert board.stop_reason is StopReason.PROGRAM_FAULT
    assert "RuntimeError: broken tick" in board.stop_message
    assert_usable(board, blink)


def test_a_firmware_call_with_pseg_at_the_top_of_xdata_wraps():
    """DPTR may point anywhere; PSeg's 16 bytes wrap at 64 KB as DPTR does."""
    image = rich()
    getlas = image.entry_points["getlas"]
    code = bytes([0x90, 0xFF, 0xF8, 0x12, getlas >> 8, getlas & 0xFF, 0x22])
    board = board_for(image)
    download(transport(board), _with_code(image, code), start=StartMode.START)
    board.advance(300)
    assert board.control_state is ControlState.RUNNING, board.stop_message
    assert board.program is not None
    xdata = board.program.cpu.xdata
    assert xdata.read(0xFFF8) == 0  # GetLAS: status 00h in PSeg[0]


# ----------------------------------------------------------------------- the property


MUTATIONS = int(os.environ.get("ASICTL_IMAGE_MUTATIONS", "300"))
#: Mutated code runs as it is: a program whose DPTR went astray writes into the DPRAM as
#: any program may (it can take the master offline, or overwrite the program buffer
#: while a download fills it), so after code mutations the host stops it first.
HEADER_AND_MAP = ("header", "map", "map")
CODE_TOO = ("header", "map", "map", "code")


@st.composite
def mutated_images(
    draw: st.DrawFn, regions: tuple[str, ...] = HEADER_AND_MAP
) -> tuple[ProgramImage, bytes, bool]:
    """A demo's image with 1-3 bytes of the regions changed, CRC fixed; whether its code
    was changed."""
    image = demo_image(draw(st.sampled_from(DEMOS)))
    data = bytearray(image.to_bytes())
    code_end = HEADER_SIZE + len(image.code)
    map_end = code_end + struct.unpack_from("<H", data, 85)[0]
    offsets = {
        "header": [*range(0, CRC.start), *range(CRC.stop, HEADER_SIZE)],
        "map": range(code_end, map_end),
        "code": range(HEADER_SIZE, code_end),
    }
    where = draw(st.lists(st.sampled_from(regions), min_size=1, max_size=3))
    for region in where:
        offset = draw(st.sampled_from(offsets[region]))
        data[offset] ^= draw(st.integers(1, 255))
    return image, with_crc(data), "code" in where


def _mutation_run(case: tuple[ProgramImage, bytes, bool]) -> None:
    image, data, code_changed = case
    try:
        ProgramImage.from_bytes(data)
    except ImageError:
        readable = False
    else:
        readable = True
    board = board_for(image)
    loaded = store_raw(board, data)
    assert loaded == (board.program_status is ProgramStatus.LOADED)
    if not readable:
        assert not loaded, "the board refuses what the host refuses"
    elif ProgramImage.from_bytes(data).entry_points.items() <= default_entry_points().items():
        assert loaded, board.program_error
    board.advance(300)
    event(f"{'loaded' if loaded else 'refused'}, {board.control_state.name.lower()}"
          f"{'' if readable else ' by the host'}")
    if loaded:
        assert board.control_state in (
            ControlState.RUNNING, ControlState.HALTED, ControlState.WAITING
        ), board.stop_message
    else:
        assert board.program is None
    if not code_changed:
        assert_usable(board, image)
        return
    set_start(transport(board), start=False)
    download(transport(board), image, start=StartMode.START)
    board.advance(300)
    assert board.program_status is ProgramStatus.LOADED and board.loaded_image == image


@settings(max_examples=MUTATIONS, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated_images())
def test_a_mutated_image_is_refused_or_runs_and_a_good_download_follows(case):
    _mutation_run(case)


@settings(max_examples=MUTATIONS // 3, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(mutated_images(CODE_TOO))
def test_mutated_code_only_ever_stops_the_program(case):
    """Whatever the code does, the board goes on: stopped, a good download loads."""
    _mutation_run(case)


@pytest.mark.slow
@settings(max_examples=8 * MUTATIONS, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(mutated_images(CODE_TOO))
def test_many_mutated_images(case):
    _mutation_run(case)
