"""The AS-i/Modbus gateway VAG-MOD-KF-R4: its Modbus address map (gateway manual chapter 7)
and the serial settings and slave addresses it can be set to (5.6).

Register numbers are Modbus PDU addresses: the manual's "41001" is holding register 1000.
The emulated gateway (``gateway.addressmap``) serves this map and the Modbus transport
(``host.transports.modbus``) reads and writes it, so both take the numbers from here.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import IntEnum

# --- the Modbus interface's settings (manual 5.6, 6.1)
#: The slave addresses the gateway can be set to ("Busadressen von 1 bis 64").
UNITS = range(1, 65)
#: The baud rates of the display codes 10-83, in the order of their first digit 1-8.
BAUD_RATES = (1200, 2400, 4800, 9600, 19200, 28800, 38400, 57600)
#: Parity ("N", "O", "E") and stop bits of the display codes' second digit 0-3: parity
#: comes with one stop bit only; two stop bits only without parity.
FRAMINGS = (("N", 1), ("O", 1), ("E", 1), ("N", 2))
#: The factory setting: code 40, 9600 baud, no parity, one stop bit.
DEFAULT_BAUD = 9600


def serial_setting_code(baud: int, parity: str, stopbits: int) -> int | None:
    """The gateway's display code of a serial setting (10..83), None if it has none."""
    if baud not in BAUD_RATES or (parity, stopbits) not in FRAMINGS:
        return None
    return 10 * (BAUD_RATES.index(baud) + 1) + FRAMINGS.index((parity, stopbits))


#: Every serial setting's code in the order the set key steps through them (5.6's table).
SERIAL_CODES = tuple(10 * b + f for b in range(1, len(BAUD_RATES) + 1) for f in range(4))


@dataclass(frozen=True)
class Interface:
    """The gateway's Modbus address and serial setting: what its keys set (5.6) and its
    EEPROM keeps."""

    unit: int = 1
    baud: int = DEFAULT_BAUD
    parity: str = "N"
    stopbits: int = 1

    @property
    def code(self) -> int:
        code = serial_setting_code(self.baud, self.parity, self.stopbits)
        assert code is not None, f"no gateway setting {self}"
        return code

    def with_code(self, code: int) -> Interface:
        """The same address with the serial setting of display code ``code``."""
        parity, stopbits = FRAMINGS[code % 10]
        return replace(
            self, baud=BAUD_RATES[code // 10 - 1], parity=parity, stopbits=stopbits
        )


#: Registers one telegram may carry (manual 6.3.3, 6.3.8).
MAX_REGISTERS = 15
#: Bits per telegram (functions 1, 2, 15): the same 30 data bytes as 15 registers.
MAX_BITS = 16 * MAX_REGISTERS
#: Function 7's byte: bit 7 = the last execution-control function failed.
EXCEPTION_STATUS_ERROR = 0x80

# --- coils (functions 1, 5, 15): four a slave where a slave has four bits
COIL_OUTPUTS = 0  # 0..127: output data, slave n bit b = 4n + b
COIL_HI_FLAGS = 128  # 128..130: the host interface flags
COIL_LPS = 200  # 200..231: list of projected slaves
COIL_PI = 300  # 300..427: parameters (PI), four bits a slave
COIL_PP = 500  # 500..627: permanent parameters (PP), four bits a slave

# --- discrete inputs (function 2)
INPUT_BIT_DATA = 0  # 0..127: input data, slave n bit b = 4n + b
INPUT_BIT_EC_FLAGS = 128  # 128..135
INPUT_BIT_LAS = 300  # 300..331
INPUT_BIT_LDS = 400  # 400..431

# --- input registers (function 4)
INPUT_DATA = 0  # 0..7: four slaves a register, slave 4k in bits 12-15
INPUT_EC_FLAGS = 8
INPUT_LAS = 9  # 9..10: slave n = bit n % 16 of register 9 + n // 16
INPUT_LDS = 11  # 11..12
INPUT_CDI = 100  # 100..131: bits 0-3 ID code, bits 4-7 I/O code

# --- holding registers (functions 3, 6, 16)
OUTPUT_DATA = 0  # 0..7: as the input data
HI_FLAGS = 8
PI = 100  # 100..131: actual parameters, one register per slave
LPS = 140  # 140..141: slave n = bit n % 16 of register 140 + n // 16
PP = 200  # 200..231: projected parameters
PCD = 300  # 300..331: bits 0-3 ID code, bits 4-7 I/O code
FLAGS_WORD = 399  # ec-flags in bits 0-7, hi-flags in 8-10 (also at 799)
FLAGS_WORD_MIRROR = 799
MEMORY_BYTES = 400  # 400..527: user memory (flag bytes F0..F127) a byte a register
INPUTS_MIRROR = 600  # 600..612: the input registers 0..12 again (writes ignored)
EC_FLAGS = 608  # = INPUTS_MIRROR + INPUT_EC_FLAGS
LAS = 609
LDS = 611
CDI = 700  # 700..731: the input registers 100..131 again
MEMORY_WORDS = 800  # 800..863: user memory two bytes a register, first byte high


class ExecutionRegister(IntEnum):
    """Holding registers 1000..1009 (the manual's 41001..41010): each write is a function."""

    SET_OPERATION_MODE = 1000  # 0 protected mode, anything else configuration mode
    CHANGE_ADDRESS_OLD = 1001
    CHANGE_ADDRESS_NEW = 1002
    STORE_ACTUAL_PARAMETERS = 1003
    STORE_ACTUAL_CONFIGURATION = 1004
    EXECUTE_COMMAND_ADDRESS = 1005
    EXECUTE_COMMAND_INFORMATION = 1006
    KEY_LOCK = 1007
    WATCHDOG = 1008
    START_STOP = 1009  # the AS-i Control flags


# --- where a control program's operands appear (the formulas docs/modbus.md tabulates)


def data_bit(slave: int, bit: int) -> int:
    """Coil (output data) or discrete input (input data) of a slave's data bit: 4n + b."""
    return 4 * slave + bit


def data_register(slave: int) -> tuple[int, int]:
    """(register, lowest bit) of a slave's nibble in the data registers: four slaves a
    register, slave 4k in bits 12-15 down to slave 4k+3 in bits 0-3."""
    return slave // 4, 12 - 4 * (slave % 4)


def memory_word(flag_byte: int) -> tuple[int, int]:
    """(holding register, lowest bit) of a flag byte in the two-bytes-a-register user
    memory: the even byte is the high byte."""
    return MEMORY_WORDS + flag_byte // 2, 0 if flag_byte % 2 else 8


def swap_profile(value: int) -> int:
    """A PCD/CDI register (bits 0-3 ID code, bits 4-7 I/O code) from the PC2's profile
    byte (ID code high, I/O code low), and the other way: the swap is its own inverse."""
    return (value & 0xF) << 4 | value >> 4 & 0xF
