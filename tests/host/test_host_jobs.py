"""Jobs in the ASI_CTRL pattern: BUSY, then DONE or ERROR with a STATUS word."""

from __future__ import annotations

import pytest
from host_helpers import ScriptedBoard

from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.host.transports.jobs import REINITIALISE, Job, JobError, JobStatus, PortError
from asictl.platform.pc2 import ACK, DATA, NAK, Command, Status


def driver_for(board: ScriptedBoard) -> Pc2Driver:
    return Pc2Driver(EmulatedPort(board))


def test_busy_then_done_with_the_result():
    def execute(board: ScriptedBoard) -> int:
        board.dpram[DATA] = 0x0A  # the slave's answer
        return ACK

    board = ScriptedBoard({Command.EXECUTE_COMMAND: execute}, delay_ms=3)
    job = Job(driver_for(board), Command.EXECUTE_COMMAND, data=0x10, address=5)
    assert not (job.busy or job.done or job.error)
    job.request()
    assert job.busy and job.status is JobStatus.BUSY_FIRST_CALL
    job.request()  # REQ again while busy: ignored, as ASI_CTRL does
    assert job.status is JobStatus.BUSY_FIRST_CALL
    job.poll()
    assert job.busy and job.status is JobStatus.BUSY
    job.poll()
    job.poll()
    assert job.done and not job.busy and not job.error
    # DONE with response data: STATUS is its length in bytes (ASI_CTRL), one byte here
    assert job.status == 1 and job.result == 0x0A
    job.poll()  # polling a finished job changes nothing
    assert job.done


def test_refused_is_error_8384():
    job = Job(driver_for(ScriptedBoard({Command.SET_LPS: lambda b: NAK})), Command.SET_LPS)
    job.request()
    job.poll()
    assert job.error and job.status == 0x8384 and job.result is None


def test_time_out_is_error_8383():
    job = Job(driver_for(ScriptedBoard()), Command.GET_STATUS, timeout_ms=10)
    job.request()
    polls = 0
    while job.busy:
        job.poll()
        polls += 1
    assert job.error and job.status == 0x8383 and polls == 10


def test_unknown_command_is_error_83f8_without_touching_the_board():
    board = ScriptedBoard()
    job = Job(driver_for(board), 99)
    job.request()
    assert job.error and job.status == 0x83F8 and board.accesses == 0


@pytest.mark.parametrize(
    ("status_byte", "expected"),
    [
        (Status.NO_SLAVE, 0x83A1),
        (Status.SLAVE_ZERO_PRESENT, 0x83A2),
        (Status.ADDRESS_OCCUPIED, 0x83A3),
        (Status.CANNOT_PROGRAM_ZERO, 0x83A4),
        (Status.CANNOT_SET_ADDRESS, 0x83A5),
        (Status.CANNOT_STORE_ADDRESS, 0x83A6),
        (Status.ERROR, 0x8384),
        (0x5A, 0x8384),
    ],
)
def test_address_change_failures_map_to_the_asi_ctrl_codes(status_byte: int, expected: int):
    def change(board: ScriptedBoard) -> int:
        board.dpram[DATA] = status_byte
        return ACK

    driver = driver_for(ScriptedBoard({Command.CHANGE_SLAVE_ADDRESS: change}))
    with pytest.raises(JobError) as caught:
        driver.command(Command.CHANGE_SLAVE_ADDRESS, data=7, address=3)
    assert caught.value.status == expected
    assert f"[STATUS {expected:04X}h]" in str(caught.value)


def test_address_change_success():
    def change(board: ScriptedBoard) -> int:
        board.dpram[DATA] = Status.OK
        return ACK

    driver = driver_for(ScriptedBoard({Command.CHANGE_SLAVE_ADDRESS: change}))
    assert driver.command(Command.CHANGE_SLAVE_ADDRESS, data=7, address=3) == Status.OK


class BrokenPort:
    """A port whose every access fails, as /dev/port does when the bus errors."""

    def read(self, offset: int) -> int:
        raise PortError("port 300h: cannot read: Input/output error")

    def write(self, offset: int, value: int) -> None:
        raise PortError("port 300h: cannot write: Input/output error")

    def now_ms(self) -> float:
        return 0.0


def test_port_failure_is_error_8383():
    job = Job(Pc2Driver(BrokenPort()), Command.GET_STATUS)
    job.request()
    assert job.error and job.status == 0x8383
    assert "Input/output error" in job.message


@pytest.mark.parametrize(
    ("status_byte", "expected"),
    [
        (Status.NO_SLAVE, 0x83A1),
        (Status.SLAVE_ZERO_PRESENT, 0x83A2),
        (Status.ADDRESS_OCCUPIED, 0x83A3),
        (Status.CANNOT_PROGRAM_ZERO, 0x83A4),
        (Status.CANNOT_SET_ADDRESS, 0x83A5),
        (Status.CANNOT_STORE_ADDRESS, 0x83A6),
        (Status.ERROR, 0x8384),
    ],
)
def test_a_refused_address_change_reads_the_status_byte(status_byte: int, expected: int):
    """The PC2 answers a failed command 20 with FFh and leaves the reason in ``data``."""

    def refuse(board: ScriptedBoard) -> int:
        board.dpram[DATA] = status_byte
        return NAK

    driver = driver_for(ScriptedBoard({Command.CHANGE_SLAVE_ADDRESS: refuse}))
    with pytest.raises(JobError) as caught:
        driver.command(Command.CHANGE_SLAVE_ADDRESS, data=7, address=3)
    assert caught.value.status == expected
    assert "3 -> 7" in str(caught.value)


def test_the_emulated_board_refuses_an_address_change_with_83a1():
    """The board's own command 20, not a script: no slave at the old address."""
    from asictl.board.board import Pc2Board

    board = Pc2Board()
    board.advance(100)
    driver = Pc2Driver(EmulatedPort(board))
    with pytest.raises(JobError) as caught:
        driver.command(Command.CHANGE_SLAVE_ADDRESS, data=10, address=9)
    assert caught.value.status == JobStatus.NO_SLAVE == 0x83A1
    assert "no slave at the old address" in str(caught.value)


def test_protected_mode_refused_for_slave_zero_is_8385():
    from asictl.board.asi import Slave
    from asictl.board.board import Pc2Board

    board = Pc2Board()
    board.bus.attach(Slave(0, 0x7, 0xF))
    board.advance(100)
    driver = Pc2Driver(EmulatedPort(board))
    with pytest.raises(JobError) as caught:
        driver.command(Command.SET_OPERATION_MODE, data=0)
    assert caught.value.status == JobStatus.SLAVE_ZERO == 0x8385


@pytest.mark.parametrize(
    ("code", "data", "length"),
    [
        (Command.SET_LPS, 0, 0),  # no response data: 0000h
        (Command.WRITE_PARAMETER, 3, 1),  # the slave's answer
        (Command.READ_CLEAR_LCS, 0, 4),
        (Command.READ_CLEAR_ERROR_COUNTERS, 0, 32),
        (Command.UPLOAD, 240, 240),  # the block the job asked for
        (Command.READ_COMM_MEMORY, 16, 16),
    ],
)
def test_done_reports_the_length_of_the_response_data(code: int, data: int, length: int):
    job = Job(driver_for(ScriptedBoard({code: lambda b: ACK})), code, data=data)
    job.run()
    assert job.done and job.status == length


def test_command_77h_ends_every_busy_job_and_the_interface_works_again():
    board = ScriptedBoard({Command.SET_LPS: lambda b: ACK})
    driver = driver_for(board)
    stuck = Job(driver, Command.GET_STATUS)  # never acknowledged by this board
    stuck.request()
    stuck.poll()
    assert stuck.busy
    accesses = board.accesses
    reinit = Job(driver, REINITIALISE)
    reinit.run()
    assert reinit.done and reinit.status == JobStatus.OK
    assert board.accesses == accesses  # the job layer's own: nothing reached the board
    assert stuck.error and stuck.status == JobStatus.INTERFACE_ERROR
    assert "re-initialised" in stuck.message
    stuck.poll()  # an ended job stays ended
    assert stuck.error
    assert Job(driver, Command.SET_LPS).run() == board.dpram[DATA]
