"""Commissioning: ASI_MON's editor mode as host procedures (docs/commissioning.md).

Changing a slave's address, writing a parameter, sending an AS-i command, switching the
operation mode, storing the actual configuration or parameters, the diagnostics (LCS,
error counters, LOS, telegram counters), the host interface flags, and writing flags and
outputs: each goes
through the master's own host commands, so one procedure serves the emulated board, a
real board through /dev/port and a live board (``Pc2Commissioning``, over the driver),
and a Modbus gateway where it offers the function (``ModbusCommissioning``, over its
execution-control registers). A function the target lacks raises ``NotOffered`` (exit 1).
Refusals are ``JobError``s with the ASI_CTRL STATUS word (host/transports/jobs.py).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from asictl.errors import ExitCode, UserError
from asictl.host.transports.driver import Pc2Driver
from asictl.host.transports.jobs import JobError, JobStatus, address_change_failure
from asictl.il.ast import OperandKind as K
from asictl.image.eeprom import Configuration
from asictl.observe.operands import Assignment
from asictl.platform import gateway
from asictl.platform.gateway import (
    EXCEPTION_STATUS_ERROR,
    MEMORY_BYTES,
    OUTPUT_DATA,
    PI,
    ExecutionRegister,
)
from asictl.platform.master import SLAVES, ControlFlag
from asictl.platform.pc2 import (
    CONTROL_FLAGS,
    FLAGS,
    FLAGS_SIZE,
    HI_FLAGS,
    LIST_SIZE,
    LOS,
    ODI,
    PROGRAM_BUFFER,
    Command,
    list_bytes,
    slave_list,
)


class NotOffered(UserError):
    """The target has no way to do this (a gateway without the function)."""

    exit_code = ExitCode.FAILED


@dataclass(frozen=True)
class Diagnostics:
    """What commands 70, 71, 72 (the LOS as it is) and 129 report; reading clears all
    but the LOS, as on the master."""

    lcs: list[int]
    error_counters: list[int]
    los: list[int]
    telegrams: int
    failed_telegrams: int


class Commissioning(Protocol):
    """The editor-mode functions; every target implements them or raises ``NotOffered``."""

    name: str

    def change_address(self, old: int, new: int) -> None: ...

    def write_parameter(self, address: int, value: int) -> int: ...

    def execute_command(self, address: int, information: int) -> int: ...

    def set_mode(self, *, configuration: bool) -> None: ...

    def store_configuration(self) -> None: ...

    def store_parameters(self) -> None: ...

    def set_configuration(self, configuration: Configuration) -> None: ...

    def diagnostics(self) -> Diagnostics: ...

    def set_los(self, addresses: list[int]) -> None: ...

    def write_flags(self, first: int, values: bytes) -> None: ...

    def read_flags(self) -> bytes: ...

    def write_outputs(self, changes: dict[int, tuple[int, int]]) -> None: ...

    def read_hi_flags(self) -> int: ...

    def write_hi_flags(self, flags: int) -> None: ...


#: The three host interface flags (platform.pc2.HiFlag) of the hi-flags byte.
HI_FLAGS_MASK = 0x07

#: A change of the master's images: (flag byte or slave, mask, bits): the bits under the
#: mask become the bits (a slave's data bits are the low four).
Change = tuple[int, int, int]
#: What ``asictl write`` writes: flags and outputs.
WRITABLE = (K.F, K.FY, K.Q, K.QB)


def image_changes(assignment: Assignment) -> list[Change]:
    """What an ``OPERAND=VALUE`` changes: flag bytes for F and FY, slaves' data bits for
    I, Q (a bit, or all four: ``Q 17``), IB and QB (two slaves); ``UserError`` for an
    operand that is neither (a timer, a variable: the program's own)."""
    node, value = assignment.operand.node, assignment.value
    n, bit = node.address, node.bit
    kind = node.kind
    if kind in (K.F, K.I, K.I2, K.Q) and bit >= 0:
        return [(n, 1 << bit, value << bit)]
    if kind in (K.I, K.I2, K.Q):
        return [(n, 0xF, value)]
    if kind is K.FY:
        return [(n, 0xFF, value)]
    if kind in (K.IB, K.I2B, K.QB):
        return [(n, 0xF, value & 0xF), (n + 1, 0xF, value >> 4)]
    raise UserError(f"'{assignment.written}' is the program's own: only flags, inputs and "
                    "outputs can be written", ExitCode.USAGE)


def image_writes(
    assignments: list[Assignment],
) -> tuple[list[Change], dict[int, tuple[int, int]]]:
    """The flag changes and the output changes (slave -> (mask, bits)) of a ``write``;
    ``UserError`` (exit 2) for an operand ``write`` does not write."""
    flags: list[Change] = []
    outputs: dict[int, tuple[int, int]] = {}
    for assignment in assignments:
        kind = assignment.operand.node.kind
        if kind not in WRITABLE:
            inputs = kind in (K.I, K.IB, K.I2, K.I2B)  # the slaves' own: the cable sets them
            again = f"'{assignment.written}={assignment.value}'"
            raise UserError(
                f"'{assignment.written}' cannot be written: write sets flags (F, FY) and "
                "outputs (Q, QB)" + (
                    f"; an input comes from its slave: asictl bus inputs {again} "
                    f"sets it on the emulated cable, asictl force {again} holds "
                    "it for the program" if inputs else ""), ExitCode.USAGE)
        changes = image_changes(assignment)
        if kind in (K.F, K.FY):
            flags += changes
            continue
        for number, mask, bits in changes:
            if not 1 <= number < SLAVES:
                raise UserError(f"'{assignment.written}': slaves 1..31 have outputs",
                                ExitCode.USAGE)
            old_mask, old_value = outputs.get(number, (0, 0))
            outputs[number] = (old_mask | mask, old_value & ~mask | bits)
    return flags, outputs


def write_flags(tools: Commissioning, changes: list[Change]) -> None:
    """Change flag bits and bytes (``image_changes`` of F and FY): each byte touched is
    read, changed under its masks and written back once."""
    memory = bytearray(tools.read_flags())
    for n, mask, bits in changes:
        memory[n] = memory[n] & ~mask | bits
    for n in sorted({n for n, _, _ in changes}):
        tools.write_flags(n, bytes([memory[n]]))


def check_address(address: int, *, zero: bool = True) -> None:
    if not (0 if zero else 1) <= address < SLAVES:
        raise UserError(
            f"slave address {address}: must be {'0' if zero else '1'}..31", ExitCode.USAGE
        )


def _refused_in_protected_mode(exc: JobError, what: str) -> JobError:
    if exc.status is JobStatus.REFUSED:
        return JobError(
            exc.status, f"{what}: refused by the master; it is only allowed in configuration "
            "mode ('asictl mode configuration')",
        )
    return exc


class Pc2Commissioning:
    """Over the PC2's DPRAM commands (manual 7.3)."""

    def __init__(self, driver: Pc2Driver, name: str) -> None:
        self.driver = driver
        self.name = name

    def change_address(self, old: int, new: int) -> None:
        """Command 20; a refusal reads the status byte: 83A1h..83A6h."""
        check_address(old)
        check_address(new)
        self.driver.command(Command.CHANGE_SLAVE_ADDRESS, data=new, address=old)

    def write_parameter(self, address: int, value: int) -> int:
        """Command 5: the parameter goes to PI and to the slave; its answer."""
        check_address(address, zero=False)
        return self._answer(
            Command.WRITE_PARAMETER, value & 0xF, address,
            refused=f"writing parameter {value:X}h to slave {address}: the slave is not "
            "active and did not answer (the PI keeps the value)",
        )

    def execute_command(self, address: int, information: int) -> int:
        """Command 22: an AS-i command call to an active slave; its answer."""
        check_address(address)
        return self._answer(
            Command.EXECUTE_COMMAND, information & 0x1F, address,
            refused=f"AS-i command {information:02X}h to slave {address}: no answer "
            "(no such slave, or it does not know the call)",
        )

    def _answer(self, command: Command, data: int, address: int, *, refused: str) -> int:
        """A slave's answer to ``command``; a refusal (the slave did not answer) says
        ``refused`` instead of the master's bare status."""
        try:
            return self.driver.command(command, data=data, address=address)
        except JobError as exc:
            if exc.status is not JobStatus.REFUSED:
                raise
            raise JobError(exc.status, refused) from None

    def set_mode(self, *, configuration: bool) -> None:
        """Command 17; protected mode with a slave 0 present is 8385h."""
        self.driver.command(Command.SET_OPERATION_MODE, data=int(configuration))

    def store_configuration(self) -> None:
        """Command 10: the detected slaves become LPS and PCD (configuration mode only)."""
        try:
            self.driver.command(Command.STORE_ACTUAL_CONFIGURATION)
        except JobError as exc:
            raise _refused_in_protected_mode(exc, "store actual configuration") from None

    def store_parameters(self) -> None:
        """Command 7: the actual parameters (PI) become the permanent ones (PP)."""
        self.driver.command(Command.STORE_ACTUAL_PARAMETER)

    def set_configuration(self, configuration: Configuration) -> None:
        from asictl.host.transfer import Pc2Transport

        Pc2Transport(self.driver).write_configuration(configuration)

    def diagnostics(self) -> Diagnostics:
        run, read = self.driver.command, self.driver.read
        run(Command.READ_CLEAR_LCS)
        lcs = sorted(slave_list(read(PROGRAM_BUFFER, LIST_SIZE)))
        run(Command.READ_CLEAR_ERROR_COUNTERS)
        counters = list(read(PROGRAM_BUFFER, SLAVES))
        run(Command.READ_TELEGRAM_COUNTERS)
        telegrams = read(PROGRAM_BUFFER, 4)
        return Diagnostics(
            lcs=lcs, error_counters=counters, los=sorted(slave_list(read(LOS, LIST_SIZE))),
            telegrams=int.from_bytes(telegrams[:2], "little"),
            failed_telegrams=int.from_bytes(telegrams[2:], "little"),
        )

    def set_los(self, addresses: list[int]) -> None:
        """Command 72: a configuration error at one of these addresses takes the master
        offline."""
        for address in addresses:
            check_address(address)
        self.driver.write(LOS, list_bytes(addresses))
        self.driver.command(Command.SET_LOS)

    def write_flags(self, first: int, values: bytes) -> None:
        if first < 0 or first + len(values) > FLAGS_SIZE:
            raise UserError(f"flag bytes F{first}..: the flags are F0..F127", ExitCode.USAGE)
        self.driver.write(FLAGS + first, values)

    def read_flags(self) -> bytes:
        return self.driver.read(FLAGS, FLAGS_SIZE)

    def read_hi_flags(self) -> int:
        return self.driver.read_byte(HI_FLAGS) & HI_FLAGS_MASK

    def write_hi_flags(self, flags: int) -> None:
        """The hi-flags byte 123h, which the master reads every AS-i cycle (manual 7.3;
        the driver message 74h, 'write host interface flags', writes the same byte)."""
        self.driver.write(HI_FLAGS, bytes([flags & HI_FLAGS_MASK]))

    def write_outputs(self, changes: dict[int, tuple[int, int]]) -> None:
        """The ODI (stored inverted): per slave (mask, bits), the output bits under the
        mask become the bits; only while no program runs, whose outputs would replace
        them in its next cycle."""
        self.driver.command(Command.GET_STATUS)
        if self.driver.read_byte(CONTROL_FLAGS) & ControlFlag.CONTROL_ACTIVE:
            raise UserError(
                "the control program is running and owns the outputs: stop it first "
                "('asictl stop')", ExitCode.FAILED,
            )
        odi = bytearray(0xFF - b for b in self.driver.read(ODI, SLAVES // 2))
        for address, (mask, bits) in changes.items():
            check_address(address, zero=False)
            shift = 4 * (address % 2)
            odi[address // 2] = odi[address // 2] & ~(mask << shift) | (bits & mask) << shift
        self.driver.write(ODI, bytes(0xFF - b for b in odi))


class GatewayRegisters(Protocol):
    """What commissioning needs of a gateway's Modbus connection (host.transports.modbus's
    ``ModbusTransport`` is the one): its registers and the replies of its execution
    control. Named here so that commissioning does not depend on the transport."""

    name: str
    unit: int

    def read_registers(self, address: int, count: int) -> list[int]: ...
    def write_registers(self, address: int, values: Sequence[int]) -> None: ...
    def execution_result(self, register: int, value: int, what: str) -> int: ...
    def write_configuration(self, configuration: Configuration) -> None: ...
    def control_flags(self) -> int: ...


class ModbusCommissioning:
    """Over the gateway's execution-control registers 1000..1009 (gateway manual 7.3)."""

    def __init__(self, transport: GatewayRegisters) -> None:
        self.transport = transport
        self.name = f"{transport.name} unit {transport.unit}"

    def _result(self, register: int, value: int, what: str) -> int:
        result = self.transport.execution_result(register, value, what)
        if result & EXCEPTION_STATUS_ERROR:
            raise JobError(JobStatus.REFUSED, f"{what}: refused by the master")
        return result & 0xF

    def change_address(self, old: int, new: int) -> None:
        check_address(old)
        check_address(new)
        self.transport.write_registers(ExecutionRegister.CHANGE_ADDRESS_OLD, [old])
        result = self.transport.execution_result(
            ExecutionRegister.CHANGE_ADDRESS_NEW, new, f"address change {old} -> {new}"
        )
        if result & EXCEPTION_STATUS_ERROR:
            status, why = address_change_failure(result & 0xF)
            raise JobError(status, f"address change {old} -> {new} failed: {why}")

    def write_parameter(self, address: int, value: int) -> int:
        check_address(address, zero=False)
        return self._result(PI + address, value & 0xF, f"writing parameter to slave {address}")

    def execute_command(self, address: int, information: int) -> int:
        check_address(address)
        self.transport.write_registers(ExecutionRegister.EXECUTE_COMMAND_ADDRESS, [address])
        return self._result(
            ExecutionRegister.EXECUTE_COMMAND_INFORMATION, information & 0x1F,
            f"AS-i command {information:02X}h to slave {address}",
        )

    def set_mode(self, *, configuration: bool) -> None:
        try:
            self._result(
                ExecutionRegister.SET_OPERATION_MODE, int(configuration), "set operation mode"
            )
        except JobError:
            if configuration:
                raise
            raise JobError(
                JobStatus.SLAVE_ZERO,
                "protected mode refused: a slave with address 0 is present",
            ) from None

    def store_configuration(self) -> None:
        try:
            self._result(
                ExecutionRegister.STORE_ACTUAL_CONFIGURATION, 1, "store actual configuration"
            )
        except JobError as exc:
            raise _refused_in_protected_mode(exc, "store actual configuration") from None

    def store_parameters(self) -> None:
        self._result(ExecutionRegister.STORE_ACTUAL_PARAMETERS, 1, "store actual parameters")

    def set_configuration(self, configuration: Configuration) -> None:
        self.transport.write_configuration(configuration)

    def diagnostics(self) -> Diagnostics:
        raise NotOffered(
            f"{self.name}: the gateway offers no LCS, error counters, LOS or telegram "
            "counters (its Modbus diagnostics are function 8's; see docs/modbus.md)"
        )

    def set_los(self, addresses: list[int]) -> None:
        raise NotOffered(f"{self.name}: the gateway has no register for the LOS")

    def write_flags(self, first: int, values: bytes) -> None:
        if first < 0 or first + len(values) > FLAGS_SIZE:
            raise UserError(f"flag bytes F{first}..: the flags are F0..F127", ExitCode.USAGE)
        self.transport.write_registers(MEMORY_BYTES + first, list(values))

    def read_flags(self) -> bytes:
        return bytes(r & 0xFF for r in self.transport.read_registers(MEMORY_BYTES, FLAGS_SIZE))

    def read_hi_flags(self) -> int:
        return self.transport.read_registers(gateway.HI_FLAGS, 1)[0] & HI_FLAGS_MASK

    def write_hi_flags(self, flags: int) -> None:
        """Holding register 8: the hi-flags as the DPRAM holds them (gateway manual 6.3)."""
        self.transport.write_registers(gateway.HI_FLAGS, [flags & HI_FLAGS_MASK])

    def write_outputs(self, changes: dict[int, tuple[int, int]]) -> None:
        if self.transport.control_flags() & ControlFlag.CONTROL_ACTIVE:
            raise UserError(
                "the control program is running and owns the outputs: stop it first "
                "('asictl stop')", ExitCode.FAILED,
            )
        registers = self.transport.read_registers(OUTPUT_DATA, 8)
        for address, (mask, bits) in changes.items():
            check_address(address, zero=False)
            shift = 4 * (3 - address % 4)
            k = address // 4
            registers[k] = registers[k] & ~(mask << shift) | (bits & mask) << shift
        self.transport.write_registers(OUTPUT_DATA, registers)
