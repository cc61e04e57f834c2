"""A compiled program downloaded through the port runs on the board: outputs, stops, restarts."""

from __future__ import annotations

import pytest
from board_host import Host, compile_image

from asictl.board.asi import Slave
from asictl.board.board import Pc2Board
from asictl.board.images import VERSION_ID
from asictl.platform import pc2 as d
from asictl.platform.master import ControlFlag
from asictl.platform.pc2 import Command, ControlState, StopReason

SETUP = "[SETUP]\n1: iiii, 1\n3: oooo, 0\n"
FOLLOW = SETUP + """
[PROGRAM]
        A   I 1.0
        =   Q 3.0
***
        AN  I 1.1
        =   Q 3.1
***
        A   F 0.0       ; set by the host
        =   Q 3.3
"""


@pytest.fixture
def slaves(board: Pc2Board) -> tuple[Slave, Slave]:
    return board.bus.attach(Slave(1, 0x0, 0x1)), board.bus.attach(Slave(3, 0x8, 0x0))


def run(host: Host, text: str) -> None:
    assert host.install(compile_image(text)) == d.ACK
    host.board.advance(30)


def test_program_drives_outputs_from_inputs(slaves, board: Pc2Board, host: Host):
    sensor, actuator = slaves
    run(host, FOLLOW)
    assert board.control_state is ControlState.RUNNING
    assert host.letters()[0] == "C"
    assert host.byte(d.STOP_REASON) == StopReason.NONE
    assert actuator.outputs == 0b0010
    assert host.outputs()[3] == 0b0010 and host.byte(d.ODI + 1) == 0xFF ^ 0x20  # inverted
    sensor.inputs = 0b0011
    board.advance(3)
    assert actuator.outputs == 0b0001 and host.outputs()[3] == 0b0001
    host.write(d.FLAGS, 1)
    board.advance(3)
    assert actuator.outputs == 0b1001


def test_the_host_cannot_override_a_running_programs_odi(slaves, board, host: Host):
    run(host, FOLLOW)
    host.set_outputs({3: 0xF})
    board.advance(3)
    assert slaves[1].outputs == 0b0010 and host.outputs()[3] == 0b0010


def test_timers_count_master_time(slaves, board, host: Host):
    run(host, SETUP + """
[PROGRAM]
        A   T 0
        JC  = end
        N
        L   KT 500
        S   T 0
***
        AN  Q 3.0
        =   Q 3.0
end:    BE
""")
    actuator = slaves[1]
    changes, last = 0, actuator.outputs
    for _ in range(500):
        board.advance(10)
        changes += actuator.outputs != last
        last = actuator.outputs
    assert 9 <= changes <= 11  # 5 s of a 500 ms blinker


def test_cycle_timeout_stops_with_outputs_0(slaves, board, host: Host):
    run(host, SETUP + "[PROGRAM]\n        A I 1.0\n        = Q 3.0\nx:      JU = x\n")
    assert board.control_state is ControlState.HALTED
    assert board.stop_reason is StopReason.CYCLE_TIMEOUT
    assert host.byte(d.STOP_REASON) == StopReason.CYCLE_TIMEOUT
    assert host.byte(d.CONTROL_STATE) == ControlState.HALTED
    assert "time-out" in board.stop_message and "machine cycles" in board.stop_message
    assert host.read(d.ODI, 16) == b"\xff" * 16 and slaves[1].outputs == 0
    assert host.letters()[0] == "c"


def test_a_timed_out_program_waits_for_the_set_button(slaves, board, host: Host):
    run(host, SETUP + "[PROGRAM]\n        A F 0.0\n        JC = x\n        BE\nx:      JU = x\n")
    assert board.control_state is ControlState.RUNNING
    host.write(d.FLAGS, 1)
    board.advance(10)
    assert board.control_state is ControlState.HALTED
    host.write(d.FLAGS, 0)
    board.advance(100)
    assert board.control_state is ControlState.HALTED  # never by itself
    board.press_set_button()
    board.advance(5)
    assert board.control_state is ControlState.RUNNING


def test_configuration_error_stops_and_auto_start_restarts(slaves, board, host: Host):
    sensor, actuator = slaves
    run(host, FOLLOW)
    host.write(d.FLAGS, 1)
    board.advance(3)
    assert actuator.outputs == 0b1010
    board.bus.remove(sensor)
    board.advance(3)
    assert board.control_state is ControlState.WAITING
    assert board.stop_reason is StopReason.CONFIG_ERROR
    assert actuator.outputs == 0 and host.read(d.ODI, 16) == b"\xff" * 16
    board.bus.attach(sensor)
    board.advance(30)
    assert board.control_state is ControlState.RUNNING
    assert actuator.outputs == 0b1010  # flags and memory kept


def test_wait_for_set_button_after_a_configuration_error(slaves, board, host: Host):
    sensor, actuator = slaves
    run(host, "[OPTIONS]\nauto_start: no\n" + FOLLOW)
    assert board.control_flags & ControlFlag.WAIT_FOR_SET_BUTTON
    board.bus.remove(sensor)
    board.advance(3)
    board.bus.attach(sensor)
    board.advance(50)
    assert board.control_state is ControlState.HALTED
    assert host.byte(d.STOP_REASON) == StopReason.CONFIG_ERROR
    assert "set button" in board.stop_message
    board.press_set_button()
    board.advance(3)
    assert board.control_state is ControlState.RUNNING and actuator.outputs == 0b0010


def test_a_new_start_by_the_host_also_restarts(slaves, board, host: Host):
    run(host, "[OPTIONS]\nauto_start: no\n" + FOLLOW)
    board.bus.remove(slaves[0])
    board.advance(3)
    board.bus.attach(slaves[0])
    board.advance(30)
    assert board.control_state is ControlState.HALTED
    assert host.control_flags(host.byte(d.CONTROL_FLAGS)) == d.ACK  # start flag still set
    board.advance(3)
    assert board.control_state is ControlState.RUNNING


def test_ignore_config_errors_keeps_running(slaves, board, host: Host):
    run(host, "[OPTIONS]\nignore_config_errors: yes\n" + FOLLOW)
    board.bus.remove(slaves[0])
    board.advance(10)
    assert board.control_state is ControlState.RUNNING
    assert not host.ec_flags() & d.EcFlag.CONFIG_OK


def test_leaving_normal_operation_stops_the_program(slaves, board, host: Host):
    run(host, FOLLOW)
    board.bus.power_fail()
    board.advance(3)
    assert board.stop_reason is StopReason.NOT_NORMAL_OPERATION
    board.bus.power_restore()
    board.advance(40)
    assert board.control_state is ControlState.RUNNING


def test_clearing_the_start_flag_stops_it(slaves, board, host: Host):
    run(host, FOLLOW)
    assert host.control_flags(0) == d.ACK
    board.advance(3)
    assert board.control_state is ControlState.IDLE
    assert board.stop_reason is StopReason.NOT_STARTED
    assert slaves[1].outputs == 0
    host.ok(Command.GET_STATUS)
    assert host.byte(d.CONTROL_FLAGS) == 0
    host.set_outputs({3: 0x6})  # an ordinary master again: the host's ODI counts
    board.advance(2)
    assert slaves[1].outputs == 0x6


def test_reset_clears_the_flags_and_loads_the_new_program(slaves, board, host: Host):
    run(host, FOLLOW)
    host.write(d.FLAGS, b"\x01\x02\x03")
    image = compile_image(SETUP + "[PROGRAM]\n        A I 1.0\n        = Q 3.2\n")
    host.download(image.to_bytes())
    board.advance(5)
    assert slaves[1].outputs == 0b1010  # the old program runs until the reset
    assert host.control_flags(ControlFlag.RESET | ControlFlag.START) == d.ACK
    board.advance(5)
    assert host.read(d.FLAGS, 3) == bytes(3)
    slaves[0].inputs = 1
    board.advance(3)
    assert slaves[1].outputs == 0b0100


def test_power_up_runs_the_stored_program(slaves, board, host: Host):
    run(host, FOLLOW)
    saved = board.nonvolatile()
    again = Pc2Board.from_nonvolatile(saved)
    again.advance(40)
    assert again.control_state is ControlState.RUNNING
    assert again.bus.slave(3).outputs == 0b0010


def test_firmware_blocks_act_on_the_master(slaves, board, host: Host):
    run(host, SETUP + """
[PROGRAM]
        JU  FB GetLAS
        L   PSeg 0
        T   FY 10
        L   PSeg 4      ; slaves 0-7
        T   FY 11
        L   PSeg 1      ; slaves 24-31
        T   FY 12
***
        L   KB 3
        T   PSeg 0
        L   KB 0Ah
        T   PSeg 1
        JU  FB SetPP
        L   PSeg 0
        T   FY 13
***
        JU  FB GetId
        L   PSeg 0
        T   FY 14
***
        L   KB 1
        T   PSeg 0
        JU  FB GetCDI
        L   PSeg 1
        T   FY 15
""")
    assert host.read(d.FLAGS + 10, 6) == bytes([0x00, 0b1010, 0x00, 0x00, VERSION_ID[0], 0x10])
    assert board.execution.pp[3] == 0xA
    assert d.nibbles(host.read(d.PP, 16))[3] == 0xA
    assert board.nonvolatile()["pp"][2:4] == "af"


def test_param_sends_to_the_slave(slaves, board, host: Host):
    run(host, SETUP + """
[PROGRAM]
        A   I  1.0
        AN  I2 1.0
        L   KP 3.6
        PARAM
""")
    slaves[0].inputs = 1
    board.advance(3)
    assert slaves[1].parameter == 6
    assert host.byte(d.FLAGS + 127) == 0x86
    assert d.nibbles(host.read(d.PI, 16))[3] == 6


def test_program_reads_and_writes_the_eeprom(slaves, board, host: Host):
    run(host, SETUP + """
[PROGRAM]
        L   KB 2
        T   PSeg 0
        L   KB 3Fh
        T   PSeg 1
        L   KB 0
        T   PSeg 2
        L   KB 55h
        T   PSeg 3
        L   KB 66h
        T   PSeg 4
        JU  FB WrEeprom
""")
    assert board.eeprom[0x3F00:0x3F02] == b"\x55\x66"
    assert host.upload(0x3F00, 2) == b"\x55\x66"


def test_cycle_times_in_10_us_units(slaves, board, host: Host):
    run(host, FOLLOW)
    host.ok(Command.GET_STATUS)
    previous = int.from_bytes(host.read(d.CYCLE_TIME_PREVIOUS, 2), "little")
    maximum = int.from_bytes(host.read(d.CYCLE_TIME_MAXIMUM, 2), "little")
    last_us = board.program.last_cycles * 12 / 11.0592
    assert previous == -(-last_us // 10) and maximum >= previous


def test_program_views(slaves, board, host: Host):
    assert board.program is None and board.loaded_image is None
    image = compile_image(FOLLOW)
    assert host.install(image) == d.ACK
    assert board.program is not None and board.program.flag(0) == 0
    assert board.loaded_image == image


def test_data_exchange_switched_off_by_the_program_stays_off(slaves, board, host: Host):
    run(host, "[OPTIONS]\nignore_config_errors: yes\n" + SETUP + """
[PROGRAM]
        A   I 1.0
        JC  = off
        BE
off:    L   KB 1
        T   PSeg 0
        JU  FB DataEx
""")
    slaves[0].inputs = 1
    board.advance(3)
    host.write(d.COMM_MEMORY + 200, 1)  # the host touches the DPRAM meanwhile
    board.advance(3)
    assert host.byte(d.HI_FLAGS) & d.HiFlag.DATA_EXCHANGE_OFF
    assert host.letters()[8] == "d"


def test_outputs_reach_the_slaves_again_after_a_short_power_failure(slaves, board, host: Host):
    """A power failure and return between two AS-i cycles resets the slaves' outputs; the
    master must send the program's outputs again (found by the state machine)."""
    _sensor, actuator = slaves
    run(host, FOLLOW)
    assert actuator.outputs == 0b0010  # Q 3.1 = not I 1.1
    board.bus.power_fail()
    board.bus.power_restore()
    board.advance(100)
    assert board.control_state is ControlState.RUNNING
    assert actuator.outputs == 0b0010

