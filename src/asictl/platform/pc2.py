"""The PC2 board's dual-port RAM map, command codes and flag bits (manual 7.2, 7.3, 10.2).

Both sides of the three-register port import this module: the emulated board lays its
state out by these addresses, the host driver reads and writes them. The addresses follow
the reconstructed map in the reading guide (the manual's extracted table is shifted by one
row; the sample drivers' constants fix it). Bytes 305h-309h are this board's own status
bytes in the manual's reserved range 305h-30Fh (see docs/master.md).
"""

from __future__ import annotations

from enum import IntEnum, IntFlag

# --- the three I/O registers (manual 7.2) -------------------------------------------

#: Offsets from the I/O base address (300h, 304h, ... 32Ch).
PORT_DATA = 0
PORT_INDEX = 1
PORT_PAGE = 2
#: PAGE register: bits 0-1 select the 256-byte page, bit 4 holds the board in reset.
PAGE_MASK = 0x03
PAGE_RESET_BIT = 0x10
#: The I/O base addresses the jumpers J1-J3 select.
IO_BASES = (0x300, 0x304, 0x308, 0x30C, 0x320, 0x324, 0x328, 0x32C)

DPRAM_SIZE = 0x400
PAGE_SIZE = 0x100

# --- page 0: identification ---------------------------------------------------------

MASTER_NAME = 0x0B0
MASTER_NAME_SIZE = 48
#: How asictl's emulation names itself, and the one way a command tells it from a real
#: master (host/overwrite_guard.py): the board's version string in the name field says
#: it, the emulated gateway's Modbus function 17 answers it. Nothing else (an address,
#: the entry table) counts, so a look-alike that does not say it is treated as real.
EMULATION_MARK = "asictl emulation"
INSTALLED_SOFTWARE = 0x0E0
INSTALLED_SOFTWARE_SIZE = 16
VERSION_ID = 0x0F0
VERSION_ID_SIZE = 8

# --- page 1: AS-i master data -------------------------------------------------------

WATCHDOG_ENABLE = 0x100
WATCHDOG_COUNTER = 0x101
IDI = 0x102
EC_FLAGS = 0x112
ODI = 0x113  # stored inverted
HI_FLAGS = 0x123
LAS = 0x124
LDS = 0x128
LPS = 0x12C
CDI = 0x130
PCD = 0x150
PI = 0x170
PP = 0x180
LOS = 0x1D0
COMMAND = 0x1F0
DATA = 0x1F1
ADDRESS = 0x1F2
ADDRESS_EXT = 0x1F3
CONFIG_OK_DELAY = 0x1FD
INTERRUPT_ENABLE = 0x1FE
INTERRUPT_EVENT = 0x1FF

#: Sizes: data images carry two slaves a byte (slave 2n in the low nibble), slave lists
#: one bit a slave (slave 0 = byte 0 bit 0), configuration images one byte a slave.
IMAGE_SIZE = 16
LIST_SIZE = 4
CONFIG_SIZE = 32

# --- pages 2-3: AS-i Control ----------------------------------------------------------

COMM_MEMORY = 0x200
COMM_MEMORY_SIZE = 256
#: The control program's flag bytes F0..F127 are 200h-27Fh.
FLAGS = 0x200
FLAGS_SIZE = 128
#: Program cycle times, 16-bit little-endian, in CYCLE_TIME_UNIT_US microseconds.
CYCLE_TIME_PREVIOUS = 0x300
CYCLE_TIME_MAXIMUM = 0x302
CYCLE_TIME_UNIT_US = 10
CONTROL_FLAGS = 0x304
#: This board's additions in the reserved range 305h-30Fh (see docs/master.md).
PROGRAM_STATUS = 0x305
STOP_REASON = 0x306
CONTROL_STATE = 0x307
#: After a cycle time-out: the code address of the jump that closes the endless loop
#: (16-bit little-endian); the host names its IL line through the image's line map.
STOP_ADDRESS = 0x308
PROGRAM_BUFFER = 0x310
PROGRAM_BUFFER_SIZE = 240

# --- commands (manual 7.3) ------------------------------------------------------------


class Command(IntEnum):
    """Codes the host writes to the command byte 1F0h."""

    SET_PERMANENT_PARAMETER = 3
    WRITE_PARAMETER = 5
    STORE_ACTUAL_PARAMETER = 7
    SET_PERMANENT_CONFIGURATION = 8
    STORE_ACTUAL_CONFIGURATION = 10
    SET_LPS = 12
    SET_OPERATION_MODE = 17
    CHANGE_SLAVE_ADDRESS = 20
    EXECUTE_COMMAND = 22
    WRITE_CONTROL_FLAGS = 50
    GET_STATUS = 51
    DOWNLOAD = 52
    UPLOAD = 53
    WRITE_COMM_MEMORY = 54
    READ_COMM_MEMORY = 56
    READ_CLEAR_LCS = 70
    READ_CLEAR_ERROR_COUNTERS = 71
    SET_LOS = 72
    UPDATE_DPRAM = 128
    READ_TELEGRAM_COUNTERS = 129
    EMC_TEST_MODE = 130

#: The commands that change nothing a program or a host could tell: refresh the control
#: flags and cycle times (51), copy the EEPROM (53) or the communication memory (56) to
#: the program buffer. ``asictl probe`` issues only these; a live board halted at a
#: breakpoint still answers them.
READ_ONLY_COMMANDS = frozenset({Command.GET_STATUS, Command.UPLOAD, Command.READ_COMM_MEMORY})


#: Command 130 (EMC test mode, manual 7.3, lines 443-457): its parameters in program buffer
#: bytes 0-5 (byte 0: bit 0 repetitions allowed, bit 1 answers checked, bits 3-7 the
#: expected answer; byte 1 the request; bytes 2-5 the slaves), its counters at bytes
#: 8-11 (requests, then failed answers, 16 bits each, low byte first).
EMC_REPETITIONS = 0x01
EMC_CHECK = 0x02
EMC_EXPECTED_SHIFT = 3
EMC_PARAMETERS_SIZE = 6
EMC_COUNTERS = 8


def emc_parameters(
    slaves: set[int] | list[int], request: int, *, expected: int | None = None,
    repetitions: bool = False,
) -> bytes:
    """Program buffer bytes 0-5 for command 130; answers are checked when ``expected`` is
    given; an empty slave list ends the mode."""
    byte0 = (EMC_REPETITIONS if repetitions else 0) | (
        0 if expected is None else EMC_CHECK | (expected & 0x1F) << EMC_EXPECTED_SHIFT
    )
    return bytes([byte0, request & 0x1F]) + list_bytes(slaves)


#: The command byte after execution.
#: How many bytes of response data each command leaves for the host (in ``data`` or at
#: the start of the program buffer; manual 10.2.6), beyond the status byte every command
#: returns. ``None``: as many as the command's ``data`` parameter asks for (a block).
#: ASI_CTRL reports this count in the STATUS of a job that ended DONE.
RESPONSE_BYTES: dict[Command, int | None] = {
    Command.WRITE_PARAMETER: 1,  # the slave's answer, in data
    Command.EXECUTE_COMMAND: 1,  # the slave's response, in data
    Command.UPLOAD: None,  # the block, in the program buffer
    Command.READ_COMM_MEMORY: None,
    Command.READ_CLEAR_LCS: 4,  # program buffer bytes 0-3
    Command.READ_CLEAR_ERROR_COUNTERS: 32,  # one byte per slave address
    Command.READ_TELEGRAM_COUNTERS: 4,
}

ACK = 0x00
NAK = 0xFF

#: The host's poll gives up after this long (the sample C driver).
COMMAND_TIMEOUT_MS = 200

#: Download/Upload address the EEPROM; 53 from ENTRY_TABLE_ADDRESS on reads the firmware's
#: function-block entry points instead (16 x 2 bytes little-endian, manual 3.8.2 order).
ENTRY_TABLE_ADDRESS = 0xFF00
ENTRY_TABLE_SIZE = 32


class Status(IntEnum):
    """The status byte (manual 10.2.7): command 20 leaves it in ``data``."""

    ERROR = 0x00
    OK = 0x01
    NO_SLAVE = 0x02
    SLAVE_ZERO_PRESENT = 0x03
    ADDRESS_OCCUPIED = 0x04
    CANNOT_PROGRAM_ZERO = 0x05
    CANNOT_SET_ADDRESS = 0x06
    CANNOT_STORE_ADDRESS = 0x07


# --- flag bytes (manual 10.2) -----------------------------------------------------------


class EcFlag(IntFlag):
    """Execution control flags, 112h (written by the master)."""

    CONFIG_OK = 0x01
    LDS_0 = 0x02
    AUTO_ADDRESS_ASSIGN = 0x04
    AUTO_ADDRESS_AVAILABLE = 0x08
    CONFIGURATION_ACTIVE = 0x10
    NORMAL_OPERATION_ACTIVE = 0x20
    APF = 0x40
    OFFLINE_READY = 0x80


class HiFlag(IntFlag):
    """Host interface flags, 123h (read by the master each cycle).

    Bits 0 and 2 are transmitted inverted: the byte 00h means data exchange active,
    not offline, automatic addressing enabled.
    """

    DATA_EXCHANGE_OFF = 0x01
    OFFLINE = 0x02
    AUTO_ADDRESS_OFF = 0x04






class InterruptSource(IntFlag):
    """Bits of interrupt enable 1FEh and interrupt event 1FFh."""

    CONFIG_OK_CHANGE = 0x01
    IDI_CHANGE = 0x02
    ASI_CYCLE = 0x04


class ProgramStatus(IntEnum):
    """305h: what the last reset (command 50 with the reset bit) found in the EEPROM."""

    LOADED = 0x00
    NOT_LOADED = 0x01  # no reset since power-up
    BAD_IMAGE = 0x02  # refused: damaged, or breaks the runtime contract


class StopReason(IntEnum):
    """306h: why the control program is not running (00h while it runs)."""

    NONE = 0x00
    NOT_STARTED = 0x01  # start flag clear
    NO_PROGRAM = 0x02  # see PROGRAM_STATUS
    NOT_NORMAL_OPERATION = 0x03  # master offline, in detection/activation, APF
    CONFIG_ERROR = 0x04
    CYCLE_TIMEOUT = 0x05
    PROGRAM_FAULT = 0x06  # the program did what no 8051 can run (an undefined opcode)


#: The stops that leave the program's code address in 308h (``STOP_ADDRESS``): the loop a
#: cycle time-out cut off, the undefined opcode of a program fault.
STOPS_AT_AN_ADDRESS = (StopReason.CYCLE_TIMEOUT, StopReason.PROGRAM_FAULT)


class ControlState(IntEnum):
    """307h: what the control program does next."""

    IDLE = 0x00  # no program or start flag clear: nothing happens by itself
    RUNNING = 0x01
    WAITING = 0x02  # starts by itself once the master permits (normal operation, config_ok)
    HALTED = 0x03  # stopped; waits for the set button or a new start by the host


# --- data representation (manual 10.2.1, 10.2.2) ----------------------------------------


def nibbles(image: bytes | bytearray) -> bytes:
    """A two-slaves-a-byte image (IDI, ODI, PI, PP) as one value per slave, slave 0 first."""
    return bytes(image[a >> 1] >> (a & 1) * 4 & 0xF for a in range(2 * len(image)))


def pack_nibbles(values: bytes | bytearray) -> bytes:
    """One value per slave packed two a byte: slave 2n low nibble, 2n+1 high nibble."""
    return bytes(
        values[2 * k] & 0xF | (values[2 * k + 1] & 0xF) << 4 for k in range(len(values) // 2)
    )


def slave_list(data: bytes | bytearray) -> set[int]:
    """The addresses in a 4-byte slave list (slave 0 = byte 0 bit 0)."""
    mask = int.from_bytes(data, "little")
    return {a for a in range(8 * len(data)) if mask >> a & 1}


def list_bytes(addresses: set[int] | list[int]) -> bytes:
    """A 4-byte slave list of the given addresses."""
    return sum(1 << a for a in set(addresses)).to_bytes(LIST_SIZE, "little")
