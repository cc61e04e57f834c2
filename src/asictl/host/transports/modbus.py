"""``Transport`` through an AS-i/Modbus gateway (VAG-MOD-KF-R4), docs/host.md "Modbus transport".

The gateway has no download command: its user-defined functions move 16 program bytes at a
time (66 writes, 67 reads, manual 6.3.13/6.3.14), the configuration is a set of holding
registers, and the AS-i Control flags are register 1009 (manual 7.3). Function 66 always
writes a whole block, so a shorter write (the magic-destroying first write of a download, a
last partial block) reads the block first and writes it back changed.

Like the PC2's command 53, function 67 from FF00h reads the firmware's entry-point table
instead of the EEPROM; the emulated gateway answers it so, which lets ``asictl download``
compile a source file against the master it talks to whatever the way there.

Time-outs and CRC errors (a frame with a bad checksum is dropped, so it too ends in a
time-out) are retried a bounded number of times by pymodbus itself; every request here is
idempotent, so repeating one is safe. Whatever still fails becomes a ``JobError`` with an
ASI_CTRL STATUS word, as a PC2 command failure does.
"""

from __future__ import annotations

import logging
import struct
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import TypeVar

from pymodbus import FramerType
from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.constants import ExcCodes
from pymodbus.exceptions import ConnectionException, ModbusException
from pymodbus.pdu import ModbusPDU
from pymodbus.pdu.other_message import ReadExceptionStatusRequest, ReportDeviceIdRequest
from pymodbus.pdu.register_message import (
    ReadHoldingRegistersRequest,
    WriteMultipleRegistersRequest,
    WriteSingleRegisterRequest,
)

from asictl.errors import UserError
from asictl.host.transports.gateway_pdus import (
    BLOCK_SIZE,
    CLIENT_PDUS,
    DownloadRequest,
    MasterInfoRequest,
    MasterInfoResponse,
    UploadRequest,
    UploadResponse,
)
from asictl.host.transports.jobs import JobError, JobStatus
from asictl.host.transports.target import (
    DEFAULT_RETRIES,
    DEFAULT_TIMEOUT_S,
    ModbusTarget,
)
from asictl.image.eeprom import Configuration
from asictl.platform import gateway as g
from asictl.platform.master import SLAVES, ControlFlag
from asictl.platform.pc2 import ENTRY_TABLE_ADDRESS, ENTRY_TABLE_SIZE
from asictl.runtime.firmware import FIRMWARE_BLOCKS

# pymodbus logs every time-out it retries; without a handler Python would print them.
logging.getLogger("pymodbus").addHandler(logging.NullHandler())

#: Flags a write of 1009 may carry; control_active only reads back.
_WRITABLE_FLAGS = 0xFF & ~ControlFlag.CONTROL_ACTIVE

_Response = TypeVar("_Response", bound=ModbusPDU)

_EXCEPTION_NAMES = {int(code): code.name.lower().replace("_", " ") for code in ExcCodes}


def _words(registers: Sequence[int]) -> list[int]:
    return [value & 0xFFFF for value in registers]


def lps_registers(lps: bytes) -> list[int]:
    """PC2 slave list (4 bytes, slave n = bit n % 8 of byte n // 8) as registers 140, 141."""
    return [lps[0] | lps[1] << 8, lps[2] | lps[3] << 8]


def slave_list(registers: Sequence[int]) -> list[int]:
    """Registers like 140/141 (LPS), 609/610 (LAS), 611/612 (LDS) as slave numbers."""
    return [n for n in range(SLAVES) if registers[n // 16] >> n % 16 & 1]


def data_nibbles(registers: Sequence[int]) -> bytes:
    """Data registers (four slaves a register, slave 4k in bits 12-15) one value a slave."""
    return bytes(registers[n // 4] >> 4 * (3 - n % 4) & 0xF for n in range(4 * len(registers)))


def _malformed(what: str, detail: str) -> JobError:
    return JobError(
        JobStatus.INTERFACE_ERROR, f"{what}: malformed answer from the gateway ({detail})"
    )


class ModbusTransport:
    """``Transport`` over a pymodbus client talking to one gateway (``unit``)."""

    block_size = BLOCK_SIZE

    def __init__(
        self, client: ModbusTcpClient | ModbusSerialClient, unit: int, name: str, retries: int
    ) -> None:
        self.client = client
        self.unit = unit
        self.name = name
        self.retries = retries
        #: when (time.monotonic) the whole work must be done, every request's time-out and
        #: retries within it; None: each request bounded alone (fleet sets a master's limit)
        self.deadline: float | None = None
        self._timeout = client.comm_params.timeout_connect or DEFAULT_TIMEOUT_S
        for response in CLIENT_PDUS:
            client.register(response)

    def _keep_deadline(self, what: str) -> None:
        """Refuse a request once the deadline has passed, and shorten its time-out so
        that it and its retries end by then: a gateway that drips each answer just
        within the time-out cannot stretch the work past it."""
        if self.deadline is None:
            return
        left = self.deadline - time.monotonic()
        if left <= 0:
            raise JobError(JobStatus.INTERFACE_ERROR,
                           f"{what}: the time limit for {self.name} ran out")
        self.client.comm_params.timeout_connect = min(self._timeout, left / (self.retries + 1))

    # --- one request, its failures as JobErrors ------------------------------------------

    def _call(self, what: str, request: ModbusPDU) -> ModbusPDU:
        """Send ``request`` and return the gateway's answer to it.

        Whatever the gateway does wrong (no answer, a reset connection, an answer that does
        not decode or belongs to another function) is a ``JobError`` with STATUS
        INTERFACE_ERROR, the word ASI_CTRL shows when the PC2's interface fails.
        """
        request.dev_id = self.unit
        self._keep_deadline(what)
        try:
            response = self.client.execute(False, request)
        except ConnectionException as exc:
            raise JobError(
                JobStatus.INTERFACE_ERROR, f"{what}: cannot reach the gateway at {self.name}"
                f" ({exc})",
            ) from None
        except ModbusException:
            raise JobError(
                JobStatus.INTERFACE_ERROR,
                f"{what}: no valid answer from unit {self.unit} at {self.name} after "
                f"{self.retries + 1} tries (time-out or CRC error)",
            ) from None
        except OSError as exc:  # reset or closed by the gateway mid-request
            raise JobError(
                JobStatus.INTERFACE_ERROR,
                f"{what}: the connection to the gateway at {self.name} was lost "
                f"({exc.strerror or exc})",
            ) from None
        except Exception as exc:  # a malformed answer, whatever pymodbus raises decoding it
            raise _malformed(what, f"{type(exc).__name__}: {exc}") from None
        if response.isError():
            code = response.exception_code
            status = (
                JobStatus.UNKNOWN_COMMAND if code == ExcCodes.ILLEGAL_FUNCTION
                else JobStatus.REFUSED
            )
            raise JobError(
                status, f"{what}: the gateway answered with exception {code} "
                f"({_EXCEPTION_NAMES.get(code, 'unknown')})",
            )
        if response.function_code != request.function_code:
            raise _malformed(what, f"an answer of function {response.function_code}")
        return response

    def _answer(self, what: str, request: ModbusPDU, kind: type[_Response]) -> _Response:
        """``_call`` for one of this project's own responses (65, 67)."""
        response = self._call(what, request)
        if not isinstance(response, kind):
            raise JobError(
                JobStatus.INTERFACE_ERROR,
                f"{what}: the gateway answered with function {response.function_code}",
            )
        return response

    def read_registers(self, address: int, count: int) -> list[int]:
        """Holding registers (function 3), at most 15 per telegram as the gateway allows."""
        values: list[int] = []
        for start in range(address, address + count, g.MAX_REGISTERS):
            n = min(g.MAX_REGISTERS, address + count - start)
            what = f"reading registers {start}..{start + n - 1}"
            registers = self._call(what, ReadHoldingRegistersRequest(address=start, count=n))
            if len(registers.registers) != n:
                raise _malformed(what, f"{len(registers.registers)} registers instead of {n}")
            values += registers.registers
        return values

    def write_registers(self, address: int, values: Sequence[int]) -> None:
        """Function 16 in telegrams of at most 15 registers; function 6 for a single one,
        which the execution-control registers expect (each write triggers its function)."""
        words = _words(values)
        if len(words) == 1:
            request: ModbusPDU = WriteSingleRegisterRequest(address=address, registers=words)
            self._call(f"writing register {address}", request)
            return
        for offset in range(0, len(words), g.MAX_REGISTERS):
            chunk = words[offset : offset + g.MAX_REGISTERS]
            start = address + offset
            self._call(
                f"writing registers {start}..{start + len(chunk) - 1}",
                WriteMultipleRegistersRequest(address=start, registers=chunk),
            )

    def execution_result(self, register: int, value: int, what: str) -> int:
        """Write an execution-control register, then Read Exception Status (function 7):
        Modbus has no result for a write, the gateway keeps it there (manual 6.3.10): bit 7
        set if the master refused, bits 0-3 its answer (a slave's, or command 20's status)."""
        self.write_registers(register, [value])
        status = self._call(f"{what}: reading its result", ReadExceptionStatusRequest()).status
        return int(status)

    def execution_control(self, register: int, value: int, what: str) -> None:
        """``execution_result``, a refusal raised as a ``JobError``."""
        if self.execution_result(register, value, what) & g.EXCEPTION_STATUS_ERROR:
            raise JobError(JobStatus.REFUSED, f"{what}: refused by the master")

    def server_id(self) -> bytes | None:
        """Function 17 (Report Slave ID): what the gateway says it is; None if it has no
        such function, as the VAG-MOD-KF-R4 manual says of the real one (6.3.9)."""
        try:
            response = self._call("reading the server ID", ReportDeviceIdRequest())
        except JobError as exc:
            if exc.status is JobStatus.UNKNOWN_COMMAND:
                return None
            raise
        return bytes(getattr(response, "identifier", b""))

    def master_info(self, part: int) -> str:
        """Function 65: name, version, installed software or version ID."""
        request = MasterInfoRequest(part)
        return self._answer("reading the master's name", request, MasterInfoResponse).text

    # --- Transport -----------------------------------------------------------------------

    def entry_points(self) -> dict[str, int]:
        """The firmware's function-block table: function 67 from FF00h, as command 53."""
        table = self.read_eeprom(ENTRY_TABLE_ADDRESS, ENTRY_TABLE_SIZE)
        addresses = struct.unpack(f"<{len(FIRMWARE_BLOCKS)}H", table)
        return dict(zip(FIRMWARE_BLOCKS, addresses, strict=True))

    def write_configuration(self, configuration: Configuration) -> None:
        """The PC2 sequence in registers: configuration mode, LPS, PCD, PP, protected mode,
        then PI so the slaves get their parameters without waiting for a restart."""
        pp = [configuration.parameter(n) for n in range(SLAVES)]
        self.execution_control(g.ExecutionRegister.SET_OPERATION_MODE, 1, "configuration mode")
        self.write_registers(g.LPS, lps_registers(configuration.lps))
        self.write_registers(g.PCD, [g.swap_profile(b) for b in configuration.pcd])
        self.write_registers(g.PP, pp)
        try:
            self.execution_control(g.ExecutionRegister.SET_OPERATION_MODE, 0, "protected mode")
        except JobError as exc:
            if exc.status is not JobStatus.REFUSED:
                raise
            # the one reason the master has to refuse it (ASI_CTRL's 8385h)
            raise JobError(
                JobStatus.SLAVE_ZERO,
                "protected mode refused: a slave with address 0 is present",
            ) from None
        self.write_registers(g.PI, pp)

    def write_eeprom(self, address: int, data: bytes) -> None:
        end = address + len(data)
        for block in range(address - address % BLOCK_SIZE, end, BLOCK_SIZE):
            lo, hi = max(address, block), min(end, block + BLOCK_SIZE)
            chunk = data[lo - address : hi - address]
            if hi - lo < BLOCK_SIZE:
                old = bytearray(self._read_block(block))
                old[lo - block : hi - block] = chunk
                chunk = bytes(old)
            self._call(f"writing {block:04X}h (function 66)", DownloadRequest(block, chunk))

    def read_eeprom(self, address: int, size: int) -> bytes:
        first = address - address % BLOCK_SIZE
        raw = b"".join(
            self._read_block(block) for block in range(first, address + size, BLOCK_SIZE)
        )
        return raw[address - first : address - first + size]

    def _read_block(self, address: int) -> bytes:
        what = f"reading {address:04X}h (function 67)"
        response = self._answer(what, UploadRequest(address=address), UploadResponse)
        if len(response.data) != BLOCK_SIZE:
            raise _malformed(what, f"{len(response.data)} bytes instead of {BLOCK_SIZE}")
        if response.address != address:
            raise JobError(
                JobStatus.INTERFACE_ERROR,
                f"reading {address:04X}h (function 67): the gateway answered for "
                f"{response.address:04X}h",
            )
        return response.data

    def control_flags(self) -> int:
        return self.read_registers(g.ExecutionRegister.START_STOP, 1)[0] & 0xFF

    def write_control_flags(self, flags: int) -> int:
        """Register 1009, checked with function 7 like the execution-control registers: the
        gateway keeps the master's answer (a refused reset: no valid program) there too."""
        self.execution_control(
            g.ExecutionRegister.START_STOP, flags & _WRITABLE_FLAGS,
            "writing the AS-i Control flags",
        )
        return self.control_flags()


# --- opening one --------------------------------------------------------------------------


def _client(
    target: ModbusTarget, timeout: float, retries: int
) -> ModbusTcpClient | ModbusSerialClient:
    if target.host is not None:
        framer = FramerType.RTU if target.rtu else FramerType.SOCKET
        return ModbusTcpClient(
            target.host, port=target.port, framer=framer, timeout=timeout, retries=retries,
            reconnect_delay=0,
        )
    return ModbusSerialClient(
        target.device or "", framer=FramerType.RTU, baudrate=target.baud, bytesize=8,
        parity=target.parity, stopbits=target.stopbits, timeout=timeout,
        retries=retries, reconnect_delay=0,
    )


@contextmanager
def open_modbus(
    target: ModbusTarget, unit: int = 1, *, timeout: float = DEFAULT_TIMEOUT_S,
    retries: int = DEFAULT_RETRIES,
) -> Iterator[ModbusTransport]:
    """A connected transport; a gateway that cannot be reached is a plain ``JobError``."""
    if unit not in g.UNITS:
        raise UserError(
            f"--unit {unit}: the gateway's Modbus address is {g.UNITS[0]}..{g.UNITS[-1]}"
        )
    if retries < 0 or timeout <= 0:
        raise UserError("--retries must be 0 or more and --timeout more than 0")
    client = _client(target, timeout, retries)
    try:
        if not client.connect():
            raise JobError(
                JobStatus.INTERFACE_ERROR,
                f"cannot open the Modbus connection to {target.described()}",
            )
        yield ModbusTransport(client, unit, str(target), retries)
    finally:
        # pymodbus leaves the sync clients' close() unannotated
        client.close()  # type: ignore[no-untyped-call]
