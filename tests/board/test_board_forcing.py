"""Forcing on the emulated board: the three points docs/commissioning.md names, each
held against a program that writes the opposite every cycle, and the forces saved."""

from __future__ import annotations

import pytest
from board_host import Host, compile_image

from asictl.board.asi import Slave
from asictl.board.board import Pc2Board
from asictl.board.forcing import Area, ForceError, Forces
from asictl.board.nonvolatile import Nonvolatile, NonvolatileError
from asictl.platform import pc2 as d

# Q 3.1 shows F 10.0 as the cycle starts, then F 10.0 follows I 1.0 (as in
# demos/edge.asi); Q 3.0 shows what the program read of I 1.1; Q 3.2 is always 1; FY 12
# is written 0 every cycle.
PROGRAM = """[SETUP]
1: iiii, 1
3: oooo, 0

[PROGRAM]
        A   F 10.0
        =   Q 3.1
***
        A   I 1.0
        =   F 10.0
***
        A   I 1.1
        =   Q 3.0
***
        ON  I 1.3
        O   I 1.3
        =   Q 3.2
***
        L   KB 0
        T   FY 12
"""


@pytest.fixture
def running(board: Pc2Board, host: Host) -> tuple[Slave, Slave]:
    slaves = board.bus.attach(Slave(1, 0x0, 0x1)), board.bus.attach(Slave(3, 0x8, 0x0))
    assert host.install(compile_image(PROGRAM)) == d.ACK
    board.advance(30)
    return slaves


def test_a_forced_flag_is_what_the_program_reads_whatever_it_writes(running, board, host):
    _, actuator = running
    assert host.byte(d.FLAGS + 10) & 1 == 0
    board.force(Area.FLAGS, 10, 0x01, 0x01)
    board.force(Area.FLAGS, 12, 0xFF, 0x55)
    board.advance(20)
    assert host.byte(d.FLAGS + 10) & 1 == 1  # the program wrote 0 from I 1.0 every cycle
    assert host.byte(d.FLAGS + 12) == 0x55
    assert actuator.outputs & 0b0010  # and read 1 as each cycle starts
    host.write(d.FLAGS + 10, 0)  # a host's write is overwritten too
    board.advance(5)
    assert host.byte(d.FLAGS + 10) & 1 == 1 and actuator.outputs & 0b0010
    assert board.release() == 2
    board.advance(5)
    assert host.byte(d.FLAGS + 10) & 1 == 0 and host.byte(d.FLAGS + 12) == 0
    assert not actuator.outputs & 0b0010


def test_a_forced_input_is_what_the_program_reads_not_what_the_dpram_shows(running, board, host):
    sensor, actuator = running
    board.force(Area.INPUTS, 1, 0b0010, 0b0010)
    board.advance(5)
    assert actuator.outputs & 0b0001  # the program read I 1.1 = 1
    assert host.inputs()[1] == sensor.inputs == 0  # the slave's own data
    assert board.release(Area.INPUTS, 1, 0b0010) == 1
    board.advance(5)
    assert not actuator.outputs & 0b0001


def test_a_forced_output_is_what_the_slave_receives(running, board, host):
    _, actuator = running
    assert actuator.outputs & 0b0100
    board.force(Area.OUTPUTS, 3, 0b0100, 0)
    board.force(Area.OUTPUTS, 3, 0b1000, 0b1000)
    board.advance(5)
    assert actuator.outputs & 0b1100 == 0b1000
    assert host.outputs()[3] & 0b1100 == 0b1000  # the ODI shows what the slave gets
    assert board.release(Area.OUTPUTS, 3, 0b1000) == 1
    board.advance(5)
    assert actuator.outputs & 0b1100 == 0  # Q 3.2 is still forced to 0
    board.release()
    board.advance(5)
    assert actuator.outputs & 0b1100 == 0b0100


def test_forces_hold_while_the_program_is_stopped_and_across_a_power_up(running, board, host):
    _, actuator = running
    board.force(Area.OUTPUTS, 3, 0b1000, 0b1000)
    board.force(Area.FLAGS, 10, 0x80, 0x80)
    host.control_flags(0)  # stop
    board.advance(10)
    assert actuator.outputs == 0b1000  # the safe outputs, the forced bit in place
    again = Pc2Board.from_nonvolatile(board.nonvolatile())
    assert again.forces.entries() == [(Area.OUTPUTS, 3, 0b1000, 0b1000),
                                      (Area.FLAGS, 10, 0x80, 0x80)]
    again.advance(50)
    assert again.dpram_byte(d.FLAGS + 10) == 0x80


def test_the_force_list_merges_and_releases_bit_by_bit():
    forces = Forces()
    forces.force(Area.FLAGS, 12, 0xFF, 0x55)
    forces.force(Area.FLAGS, 12, 0x01, 0x00)
    assert forces.entries() == [(Area.FLAGS, 12, 0xFF, 0x54)]
    assert forces.release(Area.FLAGS, 12, 0x0F)
    assert forces.entries() == [(Area.FLAGS, 12, 0xF0, 0x50)]
    assert not forces.release(Area.FLAGS, 12, 0x0F)
    assert Forces.from_json(forces.to_json()).entries() == forces.entries()
    with pytest.raises(ForceError, match="flag byte 128"):
        forces.force(Area.FLAGS, 128, 1, 1)
    with pytest.raises(ForceError, match="slave 0"):
        forces.force(Area.OUTPUTS, 0, 1, 1)
    with pytest.raises(ForceError, match="mask 10h"):
        forces.force(Area.INPUTS, 1, 0x10, 0)


def test_a_board_without_forces_saves_as_before_and_bad_forces_are_refused():
    state = Nonvolatile().to_json()
    assert "forced" not in state
    state["forced"] = {"flags": [[200, 1, 1]]}
    with pytest.raises(NonvolatileError, match="flag byte 200"):
        Nonvolatile.from_json(state)
    state["forced"] = {"timers": []}
    with pytest.raises(NonvolatileError, match="inputs, outputs and flags"):
        Nonvolatile.from_json(state)
