"""The runtime contract's fixed addresses (docs/runtime.md).

The compiled program and the master's firmware meet here: where the program's code is
linked, where the firmware's entry points are, which registers hold the IL machine's
registers, and which memory the compiler may allocate. Everything else about a program's
memory is decided per program by ``allocate`` and described to the firmware by the
program map in the image.
"""

from __future__ import annotations

from asictl.platform import pc2
from asictl.platform.master import CYCLE_TIMEOUT_MS, MACHINE_CYCLE_US
from asictl.runtime.firmware import FIRMWARE_BLOCKS

# --- code memory ------------------------------------------------------------------

#: Where the firmware's function blocks are entered by default (LCALL), 4 bytes apart,
#: in the order of the manual's table (3.8.2). A master may report other addresses.
FIRMWARE_TABLE_BASE = 0x0100
#: The return address the firmware pushes before entering the program each cycle: the
#: program's final RET lands here, which ends the cycle.
CYCLE_END = 0x00F0
#: The program's code is linked here; the firmware copies it from the EEPROM on reset.
CODE_BASE = 0x4000
CODE_LIMIT = 0x8000

# --- internal RAM -----------------------------------------------------------------

#: Register bank 0 holds the IL machine: R2/R3 the constant register (low, high),
#: R4/R5 ACCU2 (high, low), R6/R7 ACCU1 (high, low); R0/R1 are scratch.
KREG_LO, KREG_HI = 0x02, 0x03
ACCU2_HI, ACCU2_LO = 0x04, 0x05
ACCU1_HI, ACCU1_LO = 0x06, 0x07
#: Bytes the compiler may allocate to the program's data (direct addressing).
DIRECT_POOL = (*range(0x08, 0x20), *range(0x30, 0x80))
#: The bit-addressable bytes, allocated to the most used bit operands.
BIT_POOL = tuple(range(0x20, 0x30))
#: The stack grows up from here into the indirect-only upper half (SP at each cycle start).
STACK_START = 0x7F
#: PSW.5 (F0) keeps the single-bit register while byte instructions use the carry;
#: PSW.1 carries a computed status bit into ANL/ORL C.
SAVED_RLO_BIT = 0xD5
STATUS_BIT = 0xD1

# --- external data (XDATA) ----------------------------------------------------------

#: The dual-port RAM appears in XDATA at its own addresses (0000h-03FFh).
DPRAM_SIZE = pc2.DPRAM_SIZE
#: Flag byte n is byte 200h+n of the communication memory.
FLAGS_BASE = pc2.FLAGS
#: The program's own data (timers, counters, variables, PSeg) starts here.
DATA_BASE = 0x1000
DATA_LIMIT = 0x8000

#: Machine cycles one program cycle may take before the firmware stops it (200 ms).
CYCLE_BUDGET = round(CYCLE_TIMEOUT_MS * 1000 / MACHINE_CYCLE_US)


def default_entry_points() -> dict[str, int]:
    """Firmware block name (casefolded) -> entry address, when no master is asked."""
    return {name: FIRMWARE_TABLE_BASE + 4 * i for i, name in enumerate(FIRMWARE_BLOCKS)}
