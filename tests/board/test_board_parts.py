"""The board's parts on their own: DPRAM, non-volatile state, host commands."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from asictl.board.asi import AsiBus, Slave
from asictl.board.board import Pc2Board
from asictl.board.commands import HostCommands
from asictl.board.control import AsiControl
from asictl.board.dpram import COMMAND, MASTER_OWNED, PLAIN, Dpram
from asictl.board.execution import ExecutionControl
from asictl.board.images import MasterImages
from asictl.board.nonvolatile import Nonvolatile
from asictl.board.services import MasterFirmware
from asictl.platform import pc2 as d
from asictl.platform.master import CONTROL_FLAGS_NONVOLATILE, EEPROM_SIZE, SLAVES, ControlFlag


def test_host_writes_are_told_apart_by_address():
    dpram = Dpram()
    assert dpram.host_write(d.COMMAND, 52) == COMMAND
    for address in (d.IDI, d.EC_FLAGS, d.LAS + 3, d.LDS, d.CDI + 31, d.INSTALLED_SOFTWARE):
        assert dpram.host_write(address, 1) == MASTER_OWNED
    for address in (d.ODI, d.PI, d.HI_FLAGS, d.WATCHDOG_COUNTER, d.FLAGS, d.PROGRAM_BUFFER):
        assert dpram.host_write(address, 1) == PLAIN
    assert dpram.ram[d.COMMAND] == 52 and dpram.ram[d.PROGRAM_BUFFER] == 1


def test_put_stirs_only_on_a_change():
    dpram = Dpram()
    dpram.put(d.FLAGS, b"\x01\x02")
    dpram.stirred = False
    dpram.put(d.FLAGS, b"\x01\x02")
    assert not dpram.stirred
    dpram.put(d.FLAGS + 1, b"\x03")
    assert dpram.stirred and dpram.image(d.FLAGS, 2) == b"\x01\x03"


def test_interrupts_only_when_enabled_and_not_pending():
    dpram = Dpram()
    dpram.interrupt(d.InterruptSource.IDI_CHANGE)
    assert not dpram.interrupt_request and dpram.ram[d.INTERRUPT_EVENT] == 0
    dpram.ram[d.INTERRUPT_ENABLE] = d.InterruptSource.IDI_CHANGE
    dpram.stirred = False
    dpram.interrupt(d.InterruptSource.IDI_CHANGE)
    assert dpram.interrupt_request and dpram.stirred
    dpram.stirred = False
    dpram.interrupt(d.InterruptSource.IDI_CHANGE)  # already pending: no news
    assert not dpram.stirred


def test_a_new_board_saves_the_defaults():
    assert Pc2Board(bus=AsiBus()).nonvolatile() == Nonvolatile().to_json()


addresses = st.sets(st.integers(1, SLAVES - 1)).map(lambda s: sum(1 << a for a in s))


@given(
    eeprom=st.binary(max_size=64),
    flags=st.integers(0, 0xFF),
    mode=st.booleans(),
    lps=addresses,
    los=addresses,
    pcd=st.binary(min_size=SLAVES, max_size=SLAVES),
    pp=st.lists(st.integers(0, 15), min_size=SLAVES, max_size=SLAVES).map(bytes),
    delay=st.integers(0, 0xFF),
    slaves=st.lists(st.integers(0, SLAVES - 1), max_size=4),
)
def test_nonvolatile_json_round_trip(
    eeprom: bytes, flags: int, mode: bool, lps: int, los: int, pcd: bytes, pp: bytes,
    delay: int, slaves: list[int],
):
    state = Nonvolatile(
        eeprom=eeprom.ljust(EEPROM_SIZE, b"\xff"),
        control_flags=flags & CONTROL_FLAGS_NONVOLATILE,
        configuration_mode=mode, lps=lps, los=los, pcd=pcd, pp=pp, config_ok_delay=delay,
        bus=AsiBus([Slave(a) for a in slaves]),
    )
    again = Nonvolatile.from_json(state.to_json())
    assert again.to_json() == state.to_json()
    assert (again.eeprom, again.lps, again.los, again.pcd, again.pp) == (
        state.eeprom, lps, los, pcd, pp
    )
    assert [s.address for s in again.bus] == slaves


class FakeBoard:
    """The two things HostCommands asks of the board, recorded."""

    def __init__(self, loads: bool) -> None:
        self.loads = loads
        self.calls: list[str] = []

    def reload_program(self) -> bool:
        self.calls.append("reload")
        return self.loads

    def safe_outputs(self) -> None:
        self.calls.append("safe outputs")


def commands_for(board: FakeBoard) -> tuple[HostCommands, Dpram, AsiControl]:
    dpram, eeprom = Dpram(), bytearray(b"\xff" * EEPROM_SIZE)
    execution = ExecutionControl(AsiBus())
    control = AsiControl(dpram.xdata, MasterFirmware(execution, eeprom, b"00000000"), 0)
    images = MasterImages(dpram, execution, control)
    return HostCommands(board, dpram, execution, control, eeprom, images), dpram, control


def test_command_50_with_the_reset_bit_asks_the_board_to_reload():
    board = FakeBoard(loads=False)
    commands, dpram, control = commands_for(board)
    dpram.ram[d.CONTROL_FLAGS] = ControlFlag.RESET | ControlFlag.START
    assert commands.run(d.Command.WRITE_CONTROL_FLAGS) is False  # what the reload answered
    assert board.calls == ["reload", "safe outputs"]
    assert control.flags == ControlFlag.START
    assert dpram.ram[d.CONTROL_FLAGS] == ControlFlag.START  # written back, reset reads 0


def test_command_50_without_reset_leaves_the_program_alone():
    board = FakeBoard(loads=True)
    commands, dpram, _ = commands_for(board)
    dpram.ram[d.CONTROL_FLAGS] = ControlFlag.START
    assert commands.run(d.Command.WRITE_CONTROL_FLAGS) is True
    assert board.calls == []


def test_unknown_codes_are_refused_without_touching_anything():
    commands, dpram, _ = commands_for(FakeBoard(loads=True))
    before = dpram.snapshot()
    assert commands.run(131) is False and commands.run(0) is False
    assert dpram.snapshot() == before
