"""Master commands as jobs in the pattern of Siemens' ASI_CTRL (docs/host.md).

A PC2 command is asynchronous: the host writes a code to the command byte and the master
acknowledges it some time later. ASI_CTRL models exactly this with a job that is BUSY
after REQ and ends DONE or ERROR with a STATUS word, so the same pattern serves a caller
that must not block (a PLC-style cycle, a GUI, the Modbus transport) and, through
``Job.run``, one that may. The STATUS words are ASI_CTRL's where one fits, so an
engineer who knows the Siemens codes reads ours; docs/host.md has the table.
"""

from __future__ import annotations

import weakref
from enum import Enum, IntEnum
from typing import Protocol

from asictl.errors import ExitCode, UserError
from asictl.platform.pc2 import (
    ACK,
    COMMAND_TIMEOUT_MS,
    NAK,
    RESPONSE_BYTES,
    Command,
    Status,
)


class JobStatus(IntEnum):
    """STATUS words (ASI_CTRL shows them in the two middle bytes of its STATUS DWORD)."""

    #: DONE without response data (with response data STATUS is its length in bytes:
    #: ``Job.status`` is then a plain number, see ``response_length``)
    OK = 0x0000
    #: BUSY: the request was issued by this call
    BUSY_FIRST_CALL = 0x7001
    #: BUSY: a later call, the master has not acknowledged yet
    BUSY = 0x7002
    #: no acknowledge within the time-out, an acknowledge that is neither 00h nor FFh,
    #: or the port itself failed: ASI_CTRL's "AS-i interface error"
    INTERFACE_ERROR = 0x8383
    #: the master answered FFh: the command is not permitted in its current state
    REFUSED = 0x8384
    #: a slave with address 0 is present: the master refuses to leave configuration mode
    SLAVE_ZERO = 0x8385
    #: change address: no slave at the old address
    NO_SLAVE = 0x83A1
    #: change address: a slave with address 0 is present
    SLAVE_ZERO_PRESENT = 0x83A2
    #: change address: the new address is taken
    ADDRESS_OCCUPIED = 0x83A3
    #: change address: the slave could not be set to address 0
    CANNOT_CLEAR_ADDRESS = 0x83A4
    #: change address: the slave could not be set to the new address
    CANNOT_SET_ADDRESS = 0x83A5
    #: change address: the slave could not store the new address permanently
    CANNOT_STORE_ADDRESS = 0x83A6
    #: a command code the PC2 does not have: ASI_CTRL's "job number unknown"
    UNKNOWN_COMMAND = 0x83F8
    #: the EEPROM did not keep what was written, or holds no valid program image
    EEPROM_ERROR = 0x83F9


#: Command 20 leaves the manual's status byte (10.2.7) in ``data``; its failures map onto
#: ASI_CTRL's address-change codes one for one.
_ADDRESS_CHANGE_STATUS: dict[int, JobStatus] = {
    Status.ERROR: JobStatus.REFUSED,
    Status.NO_SLAVE: JobStatus.NO_SLAVE,
    Status.SLAVE_ZERO_PRESENT: JobStatus.SLAVE_ZERO_PRESENT,
    Status.ADDRESS_OCCUPIED: JobStatus.ADDRESS_OCCUPIED,
    Status.CANNOT_PROGRAM_ZERO: JobStatus.CANNOT_CLEAR_ADDRESS,
    Status.CANNOT_SET_ADDRESS: JobStatus.CANNOT_SET_ADDRESS,
    Status.CANNOT_STORE_ADDRESS: JobStatus.CANNOT_STORE_ADDRESS,
}

#: ASI_CTRL's texts for its address-change codes (manual 001).
_ADDRESS_CHANGE_TEXT: dict[JobStatus, str] = {
    JobStatus.NO_SLAVE: "no slave at the old address",
    JobStatus.SLAVE_ZERO_PRESENT: "a slave with address 0 is present",
    JobStatus.ADDRESS_OCCUPIED: "a slave with the new address is present",
    JobStatus.CANNOT_CLEAR_ADDRESS: "the slave's address cannot be cleared",
    JobStatus.CANNOT_SET_ADDRESS: "the slave's address cannot be set",
    JobStatus.CANNOT_STORE_ADDRESS: "the slave cannot store the address permanently",
}

_CODES = frozenset(Command)

#: ASI_CTRL's command 77H, "re-initialise the command interface": not a PC2 command but
#: the job layer's own, so it never reaches the board. It ends every job still busy on
#: the same port (as ASI_CTRL ends every command the master is executing) and leaves the
#: interface ready for a new job.
REINITIALISE = 0x77


def response_length(code: int, data: int) -> int:
    """The STATUS of a job that ended DONE: how many bytes of response data it has."""
    try:
        size = RESPONSE_BYTES.get(Command(code), 0)
    except ValueError:
        return 0
    return data if size is None else size


def address_change_failure(status_byte: int) -> tuple[JobStatus, str]:
    """The STATUS word and its text for command 20's status byte (manual 10.2.7)."""
    failure = _ADDRESS_CHANGE_STATUS.get(status_byte, JobStatus.REFUSED)
    why = _ADDRESS_CHANGE_TEXT.get(failure, "refused by the master")
    return failure, f"{why} (status byte {status_byte:02X}h)"


class JobError(UserError):
    """A job that ended in ERROR; ``status`` is its STATUS word."""

    exit_code = ExitCode.FAILED

    def __init__(self, status: JobStatus, message: str) -> None:
        super().__init__(f"{message} [STATUS {status:04X}h]")
        self.status = status
        self.message = message

    def during(self, step: str) -> JobError:
        """The same failure, saying which step of a procedure it stopped."""
        return JobError(self.status, f"{step}: {self.message}")


class PortError(UserError):
    """The I/O port could not be read or written (no board, no permission)."""


class CommandPort(Protocol):
    """What a job needs of the driver: issue, look at the command byte, read the result."""

    def issue(self, code: int, data: int, address: int, ext: int) -> None: ...

    def acknowledge(self) -> int: ...

    def result(self) -> int: ...

    def now_ms(self) -> float: ...


class JobState(Enum):
    IDLE = "idle"
    BUSY = "busy"
    DONE = "done"
    ERROR = "error"


#: The jobs each port has busy, for command 77H (weakly held: a port that is gone
#: takes its jobs with it).
_busy: weakref.WeakKeyDictionary[CommandPort, set[Job]] = weakref.WeakKeyDictionary()


def command_name(code: int) -> str:
    if code == REINITIALISE:
        return "command 77h (re-initialise the command interface)"
    try:
        return f"command {code} ({Command(code).name.lower().replace('_', ' ')})"
    except ValueError:
        return f"command {code}"


class Job:
    """One command: ``request()`` (REQ), then ``poll()`` until ``busy`` is False.

    ``done`` and ``error`` tell how it ended, ``status`` the STATUS word and ``result``
    the byte the master left in ``data`` (commands with a return value). The time-out is
    measured on the port's clock, so an emulated master times out in master time.
    """

    def __init__(
        self, port: CommandPort, code: int, data: int = 0, address: int = 0, ext: int = 0,
        *, timeout_ms: float = COMMAND_TIMEOUT_MS,
    ) -> None:
        self.port = port
        self.code, self.data, self.address, self.ext = code, data, address, ext
        self.timeout_ms = timeout_ms
        self.state = JobState.IDLE
        #: a ``JobStatus``, or on DONE the number of response bytes (``response_length``)
        self.status: int = JobStatus.OK
        self.result: int | None = None
        self.message = ""
        self._deadline = 0.0

    @property
    def busy(self) -> bool:
        return self.state is JobState.BUSY

    @property
    def done(self) -> bool:
        return self.state is JobState.DONE

    @property
    def error(self) -> bool:
        return self.state is JobState.ERROR

    def request(self) -> None:
        """Start the job; like REQ, ignored while the job is still busy."""
        if self.busy:
            return
        self.result, self.message = None, ""
        if self.code == REINITIALISE:
            self._reinitialise()
            return
        if self.code not in _CODES:
            self._fail(JobStatus.UNKNOWN_COMMAND, "the PC2 has no such command")
            return
        try:
            self.port.issue(self.code, self.data, self.address, self.ext)
        except PortError as exc:
            self._fail(JobStatus.INTERFACE_ERROR, str(exc))
            return
        self._deadline = self.port.now_ms() + self.timeout_ms
        self.state, self.status = JobState.BUSY, JobStatus.BUSY_FIRST_CALL
        _busy.setdefault(self.port, set()).add(self)

    def _reinitialise(self) -> None:
        """Command 77H: end every job busy on this port; each reports why."""
        for job in list(_busy.pop(self.port, ())):
            job._fail(
                JobStatus.INTERFACE_ERROR,
                "ended by command 77h (the command interface was re-initialised)",
            )
        self.result = 0  # no response data
        self.state, self.status = JobState.DONE, JobStatus.OK

    def poll(self) -> None:
        """Look at the command byte once and move to DONE or ERROR if it has changed."""
        if not self.busy:
            return
        try:
            ack = self.port.acknowledge()
            if ack == self.code:
                if self.port.now_ms() >= self._deadline:
                    self._fail(
                        JobStatus.INTERFACE_ERROR,
                        f"no acknowledge within {self.timeout_ms:g} ms (is there a board?)",
                    )
                else:
                    self.status = JobStatus.BUSY
            elif ack == NAK:
                self._refused()
            elif ack == ACK:
                self._finish(self.port.result())
            else:
                self._fail(
                    JobStatus.INTERFACE_ERROR,
                    f"invalid acknowledge {ack:02X}h (neither 00h nor FFh)",
                )
        except PortError as exc:
            self._fail(JobStatus.INTERFACE_ERROR, str(exc))

    def _refused(self) -> None:
        """FFh; where the PC2 says why (command 20's status byte in ``data``, the one
        reason command 17 has to refuse protected mode), the ASI_CTRL code that says it."""
        if self.code == Command.CHANGE_SLAVE_ADDRESS:
            self._address_change_failed(self.port.result())
        elif self.code == Command.SET_OPERATION_MODE and self.data == 0:
            self._fail(
                JobStatus.SLAVE_ZERO,
                "refused by the master: a slave with address 0 is present "
                "(give it an address first)",
            )
        else:
            self._fail(JobStatus.REFUSED, "refused by the master")

    def _address_change_failed(self, result: int) -> None:
        self.result = result
        failure, why = address_change_failure(result)
        self._fail(failure, f"address change {self.address} -> {self.data} failed: {why}")

    def _finish(self, result: int) -> None:
        self.result = result
        if self.code == Command.CHANGE_SLAVE_ADDRESS and result != Status.OK:
            self._address_change_failed(result)
            return
        self.state = JobState.DONE
        self.status = response_length(self.code, self.data)
        self._unlist()

    def _fail(self, status: JobStatus, message: str) -> None:
        self.state, self.status = JobState.ERROR, status
        self.message = f"{command_name(self.code)}: {message}"
        self._unlist()

    def _unlist(self) -> None:
        busy = _busy.get(self.port)
        if busy is not None:
            busy.discard(self)

    def run(self) -> int:
        """Request, poll to the end, and return ``result``; an ERROR raises ``JobError``."""
        self.request()
        while self.busy:
            self.poll()
        if self.error:
            raise JobError(JobStatus(self.status), self.message)
        assert self.result is not None
        return self.result
