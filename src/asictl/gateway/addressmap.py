"""The VAG-MOD-KF-R4's Modbus address map (gateway manual chapter 7) over a PC2 master model.

The gateway is a Modbus slave in front of the same AS-i master with AS-i Control that the
PC2 card carries, so this map owns no AS-i state: it reads the master's DPRAM and writes it,
and runs the master's host commands, through the board's own register interface
(``Pc2Driver`` over ``EmulatedPort``). What the Modbus side changes is then exactly what a
download, upload or status over the PC2 port sees, and vice versa.

Only the gateway's own settings live here: the key lock, the Modbus watchdog time, the
addresses latched for Change_Slave_Address / Execute_Command, and the return value of the
last execution-control function (function 7). Layouts and inversions: docs/modbus.md.
"""

from __future__ import annotations

from collections.abc import Callable, Container
from dataclasses import dataclass
from enum import IntEnum
from functools import partial
from typing import TypeVar

from asictl.board.board import Pc2Board
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.host.transports.jobs import JobError
from asictl.platform import gateway as g
from asictl.platform import pc2 as d
from asictl.platform.gateway import (
    EXCEPTION_STATUS_ERROR,
    MAX_BITS,
    MAX_REGISTERS,
    ExecutionRegister,
)
from asictl.platform.master import SLAVES, ControlFlag
from asictl.platform.pc2 import Command, Status

#: What a Modbus address holds: a coil, an input bit, a register address.
Item = TypeVar("Item")


class ExceptionCode(IntEnum):
    """Modbus exception codes the gateway answers with."""

    ILLEGAL_FUNCTION = 1
    ILLEGAL_DATA_ADDRESS = 2
    ILLEGAL_DATA_VALUE = 3
    SLAVE_DEVICE_FAILURE = 4


class ModbusError(Exception):
    """A request the gateway answers with an exception response."""

    def __init__(self, code: ExceptionCode, message: str) -> None:
        super().__init__(message)
        self.code = code




@dataclass
class GatewaySettings:
    """The gateway's own volatile state (all of it is lost at power-off, as on the device)."""

    key_lock: bool = False
    #: Modbus watchdog time in 10 ms units, 0 = off
    watchdog: int = 0
    #: longest pause between two telegrams to this slave while the watchdog is on, 10 ms units
    longest_pause: int = 0
    change_address_old: int = 0
    execute_command_address: int = 0
    last_new_address: int = 0
    last_information: int = 0
    exception_status: int = 0


def _bit(value: int, bit: int) -> bool:
    return bool(value >> bit & 1)


class AddressMap:
    """Coils, discrete inputs, holding and input registers of chapter 7 over one board."""

    def __init__(self, board: Pc2Board) -> None:
        self.board = board
        self.driver = Pc2Driver(EmulatedPort(board))
        self.settings = GatewaySettings()
        self._holding_readers, self._holding_writers = self._holding_table()

    # ------------------------------------------------------------------ DPRAM access

    def _ram(self, address: int, size: int = 1) -> bytes:
        return self.board.dpram[address : address + size]

    def _byte(self, address: int) -> int:
        return self.board.dpram_byte(address)

    def _nibble(self, image: int, slave: int) -> int:
        return self._byte(image + slave // 2) >> (slave & 1) * 4 & 0xF

    def _list(self, address: int) -> int:
        return int.from_bytes(self._ram(address, d.LIST_SIZE), "little")

    def command(
        self, code: Command, data: int = 0, address: int = 0, ext: int = 0
    ) -> tuple[bool, int]:
        """Run a host command to its end: (acknowledged, the byte it left in ``data``)."""
        try:
            return True, self.driver.command(code, data, address, ext)
        except JobError:
            return False, self.driver.read_byte(d.DATA)

    def _record(self, ok: bool, answer: int = 0) -> None:
        """Function 7's byte for the execution-control function just performed."""
        self.settings.exception_status = (0 if ok else EXCEPTION_STATUS_ERROR) | answer & 0xF

    # ------------------------------------------------------------------ output data, PI, PP

    def _odi(self) -> bytearray:
        """The output image as values (the DPRAM holds it inverted)."""
        return bytearray(255 - b for b in self._ram(d.ODI, d.IMAGE_SIZE))

    def _write_odi(self, image: bytearray) -> None:
        self.driver.write(d.ODI, bytes(255 - b for b in image))

    def _output_nibble(self, slave: int) -> int:
        return self._odi()[slave // 2] >> (slave & 1) * 4 & 0xF

    def _set_output_nibbles(self, values: dict[int, int]) -> None:
        image = self._odi()
        for slave, value in values.items():
            shift = (slave & 1) * 4
            image[slave // 2] = image[slave // 2] & ~(0xF << shift) | (value & 0xF) << shift
        self._write_odi(image)

    def _write_parameter(self, slave: int, value: int) -> None:
        """Write_Parameter (command 5): function 7 gets the slave's answer in bits 0-3."""
        ok, answer = self.command(Command.WRITE_PARAMETER, value, slave)
        self._record(ok, answer if ok else 0)

    def _set_permanent_parameters(self, values: dict[int, int]) -> None:
        pp = bytearray(d.nibbles(self._ram(d.PP, d.IMAGE_SIZE)))
        for slave, value in values.items():
            pp[slave] = value
        self.driver.write(d.PP, d.pack_nibbles(pp))
        self._record(self.command(Command.SET_PERMANENT_PARAMETER)[0])

    def _set_lps(self, lps: int) -> None:
        self.driver.write(d.LPS, lps.to_bytes(d.LIST_SIZE, "little"))
        self._record(self.command(Command.SET_LPS)[0])

    def _set_pcd(self, values: dict[int, int]) -> None:
        """Modbus PCD: ID code in bits 0-3, I/O code in 4-7; the DPRAM byte is the other way."""
        pcd = bytearray(self._ram(d.PCD, d.CONFIG_SIZE))
        for slave, value in values.items():
            pcd[slave] = g.swap_profile(value)
        self.driver.write(d.PCD, bytes(pcd))
        self._record(self.command(Command.SET_PERMANENT_CONFIGURATION)[0])

    def _set_hi_flags(self, bits: int) -> None:
        """hi-flags as Modbus shows them: bits 0 and 2 inverted, exactly the DPRAM byte 123h."""
        self.driver.write_byte(d.HI_FLAGS, bits & 0x07)

    # ------------------------------------------------------------------ coils

    def _coil(self, address: int) -> tuple[Callable[[], bool], Callable[[bool], None]] | None:
        """Reader and writer of one coil, or None where the map has none."""
        if g.COIL_OUTPUTS <= address < g.COIL_OUTPUTS + 4 * SLAVES:
            slave, bit = divmod(address - g.COIL_OUTPUTS, 4)
            return (
                lambda: _bit(self._output_nibble(slave), bit),
                lambda on: self._set_output_nibbles(
                    {slave: self._output_nibble(slave) & ~(1 << bit) | on << bit}
                ),
            )
        if g.COIL_HI_FLAGS <= address < g.COIL_HI_FLAGS + 3:
            bit = address - g.COIL_HI_FLAGS
            return (
                lambda: _bit(self._byte(d.HI_FLAGS), bit),
                lambda on: self._set_hi_flags(self._byte(d.HI_FLAGS) & ~(1 << bit) | on << bit),
            )
        if g.COIL_LPS <= address < g.COIL_LPS + SLAVES:
            slave = address - g.COIL_LPS
            return (
                lambda: _bit(self._list(d.LPS), slave),
                lambda on: self._set_lps(self._list(d.LPS) & ~(1 << slave) | on << slave),
            )
        if g.COIL_PI <= address < g.COIL_PI + 4 * SLAVES:
            slave, bit = divmod(address - g.COIL_PI, 4)
            return (
                lambda: _bit(self._nibble(d.PI, slave), bit),
                lambda on: self._write_parameter(
                    slave, self._nibble(d.PI, slave) & ~(1 << bit) | on << bit
                ),
            )
        if g.COIL_PP <= address < g.COIL_PP + 4 * SLAVES:
            slave, bit = divmod(address - g.COIL_PP, 4)
            return (
                lambda: _bit(self._nibble(d.PP, slave), bit),
                lambda on: self._set_permanent_parameters(
                    {slave: self._nibble(d.PP, slave) & ~(1 << bit) | on << bit}
                ),
            )
        return None

    def _coils(
        self, address: int, count: int
    ) -> list[tuple[Callable[[], bool], Callable[[bool], None]]]:
        return _every(address, count, MAX_BITS, self._coil, "coil")

    def read_coils(self, address: int, count: int) -> list[bool]:
        return [read() for read, _ in self._coils(address, count)]

    def write_coils(self, address: int, values: list[bool]) -> None:
        for (_, write), value in zip(self._coils(address, len(values)), values, strict=True):
            write(bool(value))

    # ------------------------------------------------------------------ discrete inputs

    def _input_bit(self, address: int) -> bool | None:
        if g.INPUT_BIT_DATA <= address < g.INPUT_BIT_DATA + 4 * SLAVES:
            slave, bit = divmod(address - g.INPUT_BIT_DATA, 4)
            return _bit(self._nibble(d.IDI, slave), bit)
        if g.INPUT_BIT_EC_FLAGS <= address < g.INPUT_BIT_EC_FLAGS + 8:
            return _bit(self._byte(d.EC_FLAGS), address - g.INPUT_BIT_EC_FLAGS)
        if g.INPUT_BIT_LAS <= address < g.INPUT_BIT_LAS + SLAVES:
            return _bit(self._list(d.LAS), address - g.INPUT_BIT_LAS)
        if g.INPUT_BIT_LDS <= address < g.INPUT_BIT_LDS + SLAVES:
            return _bit(self._list(d.LDS), address - g.INPUT_BIT_LDS)
        return None

    def read_discrete_inputs(self, address: int, count: int) -> list[bool]:
        return _every(address, count, MAX_BITS, self._input_bit, "discrete input")

    # ------------------------------------------------------------------ register layouts

    def _data_register(self, nibble: Callable[[int], int], k: int) -> int:
        """Four slaves a register: slave 4k in bits 12-15 ... slave 4k+3 in bits 0-3."""
        return sum(nibble(4 * k + j) << 4 * (3 - j) for j in range(4))

    def _list_word(self, address: int, half: int) -> int:
        return self._list(address) >> 16 * half & 0xFFFF

    def _pcd_register(self, image: int, slave: int) -> int:
        """DPRAM byte (I/O low, ID high) as Modbus shows it (ID low, I/O next)."""
        return g.swap_profile(self._byte(image + slave))

    def _flags_word(self) -> int:
        return self._byte(d.EC_FLAGS) | (self._byte(d.HI_FLAGS) & 0x07) << 8

    def _memory_byte(self, n: int) -> int:
        return self._byte(d.FLAGS + n)

    def _memory_word(self, k: int) -> int:
        return self._memory_byte(2 * k) << 8 | self._memory_byte(2 * k + 1)

    def _input_registers(self) -> dict[int, Callable[[], int]]:
        table: dict[int, Callable[[], int]] = {}
        for k in range(8):
            table[g.INPUT_DATA + k] = partial(self._data_register, partial(self._nibble, d.IDI), k)
        table[g.INPUT_EC_FLAGS] = lambda: self._byte(d.EC_FLAGS)
        for half in range(2):
            table[g.INPUT_LAS + half] = partial(self._list_word, d.LAS, half)
            table[g.INPUT_LDS + half] = partial(self._list_word, d.LDS, half)
        for slave in range(SLAVES):
            table[g.INPUT_CDI + slave] = partial(self._pcd_register, d.CDI, slave)
        return table

    def _holding_table(
        self,
    ) -> tuple[dict[int, Callable[[], int]], dict[int, Callable[[dict[int, int]], None]]]:
        """Readers per holding register and writers per group (a group is one command)."""
        read: dict[int, Callable[[], int]] = {}
        write: dict[int, Callable[[dict[int, int]], None]] = {}

        def output_register(k: int) -> int:
            value = self._data_register(self._output_nibble, k)
            return value & 0x0FFF if k == 0 else value  # slave 0's bits are reserved

        def write_outputs(values: dict[int, int]) -> None:
            nibbles = {}
            for k, value in values.items():
                for j in range(4):
                    if 4 * k + j:
                        nibbles[4 * k + j] = value >> 4 * (3 - j) & 0xF
            self._set_output_nibbles(nibbles)

        for k in range(8):
            read[g.OUTPUT_DATA + k] = partial(output_register, k)
            write[g.OUTPUT_DATA + k] = write_outputs
        read[g.HI_FLAGS] = lambda: self._byte(d.HI_FLAGS) & 0x07
        write[g.HI_FLAGS] = lambda values: self._set_hi_flags(values[g.HI_FLAGS])
        for slave in range(SLAVES):
            read[g.PI + slave] = partial(self._nibble, d.PI, slave)
            write[g.PI + slave] = self._write_parameters
            read[g.PP + slave] = partial(self._nibble, d.PP, slave)
            write[g.PP + slave] = lambda v: self._set_permanent_parameters(
                {a - g.PP: x for a, x in v.items()}
            )
            read[g.PCD + slave] = partial(self._pcd_register, d.PCD, slave)
            write[g.PCD + slave] = lambda v: self._set_pcd({a - g.PCD: x for a, x in v.items()})
        for half in range(2):
            read[g.LPS + half] = partial(self._list_word, d.LPS, half)
            write[g.LPS + half] = self._write_lps_words
        read[g.FLAGS_WORD] = read[g.FLAGS_WORD_MIRROR] = self._flags_word
        write[g.FLAGS_WORD] = write[g.FLAGS_WORD_MIRROR] = lambda v: self._set_hi_flags(
            next(iter(v.values())) >> 8
        )
        for n in range(d.FLAGS_SIZE):
            read[g.MEMORY_BYTES + n] = partial(self._memory_byte, n)
            write[g.MEMORY_BYTES + n] = self._write_memory_bytes
        for k in range(d.FLAGS_SIZE // 2):
            read[g.MEMORY_WORDS + k] = partial(self._memory_word, k)
            write[g.MEMORY_WORDS + k] = self._write_memory_words
        ignore: Callable[[dict[int, int]], None] = lambda values: None  # noqa: E731
        inputs = self._input_registers()
        for offset in range(g.INPUT_LDS + 2):  # data, ec-flags, LAS, LDS: writes ignored
            read[g.INPUTS_MIRROR + offset] = inputs[offset]
            write[g.INPUTS_MIRROR + offset] = ignore
        for slave in range(SLAVES):
            read[g.CDI + slave] = inputs[g.INPUT_CDI + slave]
            write[g.CDI + slave] = ignore
        for register in ExecutionRegister:
            read[register] = partial(self._read_execution, register)
            write[register] = self._write_execution
        return read, write

    # ------------------------------------------------------------------ holding writers

    def _write_parameters(self, values: dict[int, int]) -> None:
        for address, value in values.items():
            self._write_parameter(address - g.PI, value)

    def _write_lps_words(self, values: dict[int, int]) -> None:
        lps = self._list(d.LPS)
        for address, value in values.items():
            shift = 16 * (address - g.LPS)
            lps = lps & ~(0xFFFF << shift) | value << shift
        self._set_lps(lps)

    def _write_memory_bytes(self, values: dict[int, int]) -> None:
        for address, value in values.items():
            self.driver.write_byte(d.FLAGS + address - g.MEMORY_BYTES, value)

    def _write_memory_words(self, values: dict[int, int]) -> None:
        for address, value in values.items():
            self.driver.write(d.FLAGS + 2 * (address - g.MEMORY_WORDS), value.to_bytes(2, "big"))

    # ------------------------------------------------------------------ execution control

    def _read_execution(self, register: ExecutionRegister) -> int:
        s = self.settings
        if register is ExecutionRegister.SET_OPERATION_MODE:
            return int(self.board.mode == "configuration")
        if register is ExecutionRegister.START_STOP:
            self.command(Command.GET_STATUS)
            return self._byte(d.CONTROL_FLAGS) & ~ControlFlag.RESET & 0x3F
        if register is ExecutionRegister.WATCHDOG:
            return s.longest_pause if s.watchdog else 0
        return {
            ExecutionRegister.CHANGE_ADDRESS_OLD: s.change_address_old,
            ExecutionRegister.CHANGE_ADDRESS_NEW: s.last_new_address,
            ExecutionRegister.STORE_ACTUAL_PARAMETERS: 0,
            ExecutionRegister.STORE_ACTUAL_CONFIGURATION: 0,
            ExecutionRegister.EXECUTE_COMMAND_ADDRESS: s.execute_command_address,
            ExecutionRegister.EXECUTE_COMMAND_INFORMATION: s.last_information,
            ExecutionRegister.KEY_LOCK: int(s.key_lock),
        }[register]

    def _write_execution(self, values: dict[int, int]) -> None:
        for address, value in values.items():
            self._execute(ExecutionRegister(address), value)

    def _execute(self, register: ExecutionRegister, value: int) -> None:
        s = self.settings
        if register is ExecutionRegister.SET_OPERATION_MODE:
            self._record(self.command(Command.SET_OPERATION_MODE, int(value != 0))[0])
        elif register is ExecutionRegister.CHANGE_ADDRESS_OLD:
            s.change_address_old = value
        elif register is ExecutionRegister.CHANGE_ADDRESS_NEW:
            s.last_new_address = value
            ok, status = self.command(Command.CHANGE_SLAVE_ADDRESS, value, s.change_address_old)
            self._record(ok, 0 if ok else status or Status.ERROR)
        elif register is ExecutionRegister.STORE_ACTUAL_PARAMETERS:
            if value:
                self._record(self.command(Command.STORE_ACTUAL_PARAMETER)[0])
        elif register is ExecutionRegister.STORE_ACTUAL_CONFIGURATION:
            if value:
                self._record(self.command(Command.STORE_ACTUAL_CONFIGURATION)[0])
        elif register is ExecutionRegister.EXECUTE_COMMAND_ADDRESS:
            s.execute_command_address = value
        elif register is ExecutionRegister.EXECUTE_COMMAND_INFORMATION:
            s.last_information = value
            ok, answer = self.command(Command.EXECUTE_COMMAND, value, s.execute_command_address)
            self._record(ok, answer if ok else 0)
        elif register is ExecutionRegister.KEY_LOCK:
            s.key_lock = value != 0
        elif register is ExecutionRegister.WATCHDOG:
            s.watchdog, s.longest_pause = value, 0
            self.feed_watchdog()
        else:
            self.driver.write_byte(d.CONTROL_FLAGS, value & 0x1F)
            self._record(self.command(Command.WRITE_CONTROL_FLAGS)[0])

    def feed_watchdog(self, pause_ms: float = 0.0) -> None:
        """A telegram for this slave arrived: the master's own watchdog (100h/101h) restarts.

        The master then does what the gateway manual asks of a time-out: it clears the
        enable byte, sets the hi-flag offline and stays offline until that flag is cleared.
        """
        s = self.settings
        if s.watchdog:
            s.longest_pause = max(s.longest_pause, min(255, round(pause_ms / 10)))
            self.driver.write(d.WATCHDOG_ENABLE, bytes([1, s.watchdog]))
        elif self._byte(d.WATCHDOG_ENABLE):
            self.driver.write(d.WATCHDOG_ENABLE, bytes([0, 0]))

    def restart_master(self) -> None:
        """Diagnostics "restart communications": watchdog off, the master through offline."""
        self.settings.watchdog = 0
        self.feed_watchdog()
        hi = self._byte(d.HI_FLAGS)
        self._set_hi_flags(hi | d.HiFlag.OFFLINE)
        self.board.advance(10)
        self._set_hi_flags(hi & ~d.HiFlag.OFFLINE)

    # ------------------------------------------------------------------ registers

    def _check_registers(
        self, table: Container[int], address: int, count: int, what: str
    ) -> list[int]:
        return _every(
            address, count, MAX_REGISTERS, lambda a: a if a in table else None, what
        )

    def read_holding_registers(self, address: int, count: int) -> list[int]:
        span = self._check_registers(self._holding_readers, address, count, "holding register")
        return [self._holding_readers[a]() for a in span]

    def read_input_registers(self, address: int, count: int) -> list[int]:
        inputs = self._input_registers()
        span = self._check_registers(inputs, address, count, "input register")
        return [inputs[a]() for a in span]

    def write_registers(self, address: int, values: list[int]) -> None:
        """Function 6/16: every register is checked before any is written."""
        span = self._check_registers(
            self._holding_writers, address, len(values), "holding register"
        )
        for a, value in zip(span, values, strict=True):
            if value > _register_limit(a):
                raise ModbusError(
                    ExceptionCode.ILLEGAL_DATA_VALUE, f"{value} is out of range for register {a}"
                )
        groups: dict[Callable[[dict[int, int]], None], dict[int, int]] = {}
        for a, value in zip(span, values, strict=True):
            groups.setdefault(self._holding_writers[a], {})[a] = value
        for writer, group in groups.items():
            writer(group)

    def exception_status(self) -> int:
        return self.settings.exception_status

    def diagnostic_register(self) -> int:
        """Function 8 code 2: ec-flags in bits 0-7, hi-flags (as in register 399) in 8-10."""
        return self._flags_word()

    def installed_software(self) -> str:
        """The gateway's 16 letters "CBFE....DOA...WT" from the master's string at 0E0h:
        C, B, F, E and D, O, A are the master's, W and T the gateway's own."""
        master = self._ram(d.INSTALLED_SOFTWARE, d.INSTALLED_SOFTWARE_SIZE).decode("ascii")
        return (
            master[0:4] + "...." + master[8:11] + "..."
            + ("W" if self.settings.watchdog else "w")
            + ("t" if self.settings.key_lock else "T")
        )


def _every(
    address: int, count: int, limit: int, find: Callable[[int], Item | None], what: str
) -> list[Item]:
    """What ``find`` gives for each of ``count`` addresses from ``address``. A telegram
    with too many items, or with one address that has nothing, is refused whole."""
    _check_count(count, limit)
    found = []
    for a in range(address, address + count):
        item = find(a)
        if item is None:
            raise ModbusError(ExceptionCode.ILLEGAL_DATA_ADDRESS, f"no {what} at {a}")
        found.append(item)
    return found


def _check_count(count: int, limit: int) -> None:
    if not 1 <= count <= limit:
        raise ModbusError(
            ExceptionCode.ILLEGAL_DATA_VALUE, f"{count} items in one telegram (1..{limit})"
        )


def _register_limit(address: int) -> int:
    """The largest value a holding register takes (larger values: exception 3)."""
    if g.PI <= address < g.PI + SLAVES or g.PP <= address < g.PP + SLAVES:
        return 0xF
    if address == g.HI_FLAGS:
        return 0x7
    if g.PCD <= address < g.PCD + SLAVES or g.MEMORY_BYTES <= address < g.MEMORY_BYTES + 128:
        return 0xFF
    if address in (g.FLAGS_WORD, g.FLAGS_WORD_MIRROR):
        return 0x7FF
    if address in (ExecutionRegister.CHANGE_ADDRESS_OLD, ExecutionRegister.CHANGE_ADDRESS_NEW,
                   ExecutionRegister.EXECUTE_COMMAND_ADDRESS):
        return SLAVES - 1
    if address == ExecutionRegister.EXECUTE_COMMAND_INFORMATION:
        return 0x1F
    if address in (ExecutionRegister.WATCHDOG, ExecutionRegister.START_STOP):
        return 0xFF
    return 0xFFFF


__all__ = [
    "MAX_BITS",
    "MAX_REGISTERS",
    "AddressMap",
    "ExceptionCode",
    "ExecutionRegister",
    "ModbusError",
]
