"""The AS-i master's firmware function blocks (manual 3.8).

Control programs call these with ``JU FB name`` without declaring them; they exchange
data through the 16-byte parameter segment PSeg. This table is the one place that names
them, for the checks, the code generator and the emulated master.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol


@dataclass(frozen=True)
class FirmwareBlock:
    name: str
    description: str
    #: what the block reads from PSeg before it runs
    inputs: str
    #: what it leaves in PSeg
    outputs: str
    #: PSeg[0] names a slave the block sends to or reads from as a projected slave
    #: (parameters, commands): for a slave not in [SETUP] the call cannot do its job
    for_projected_slave: bool = False
    #: the PSeg bytes that carry what a slave answered: the block sends on the AS-i cable,
    #: which a real master does in its management phase (manual 3.4.6), so the answer may
    #: not be there in the cycle that called it (W718); empty for the blocks that only
    #: read or write the master's own memory
    slave_answer: tuple[int, ...] = ()


_BLOCKS = (
    FirmwareBlock(
        "SetPP",
        "write power-up parameter (PP)",
        "PSeg[0] slave address, PSeg[1] parameter",
        "PSeg[0] 00h success / 80h error",
        for_projected_slave=True,
    ),
    FirmwareBlock(
        "GetPP",
        "read power-up parameter (PP)",
        "PSeg[0] slave address",
        "PSeg[0] status, PSeg[1] parameter",
        for_projected_slave=True,
    ),
    FirmwareBlock(
        "SendPrm",
        "send parameter to a slave (PI); what PARAM calls",
        "PSeg[0] slave address, PSeg[1] parameter",
        "PSeg[0] status, PSeg[1] the slave's response",
        for_projected_slave=True,
        slave_answer=(0, 1),
    ),
    FirmwareBlock(
        "GetPI",
        "read the parameter image (PI)",
        "PSeg[0] slave address",
        "PSeg[0] status, PSeg[1] parameter",
        for_projected_slave=True,
    ),
    FirmwareBlock(
        "GetPCD",
        "read the projected slave profile (PCD)",
        "PSeg[0] slave address",
        "PSeg[0] status, PSeg[1] profile",
    ),
    FirmwareBlock(
        "GetCDI",
        "read the detected slave profile (CDI)",
        "PSeg[0] slave address",
        "PSeg[0] status, PSeg[1] profile",
    ),
    FirmwareBlock(
        "GetLPS",
        "read the list of projected slaves (LPS)",
        "none",
        "PSeg[0] status, PSeg[1..4] slaves 24-31, 16-23, 8-15, 0-7",
    ),
    FirmwareBlock(
        "GetLAS",
        "read the list of activated slaves (LAS)",
        "none",
        "PSeg[0] status, PSeg[1..4] slaves 24-31, 16-23, 8-15, 0-7",
    ),
    FirmwareBlock(
        "GetLDS",
        "read the list of detected slaves (LDS)",
        "none",
        "PSeg[0] status, PSeg[1..4] slaves 24-31, 16-23, 8-15, 0-7",
    ),
    FirmwareBlock(
        "DataEx",
        "switch data exchange off or on",
        "PSeg[0] 0 activate / not 0 deactivate",
        "PSeg[0] status",
    ),
    FirmwareBlock(
        "Address",
        "change a slave's address",
        "PSeg[0] old address, PSeg[1] new address",
        "PSeg[0] 00h success, 82h..87h failures",
        slave_answer=(0,),
    ),
    FirmwareBlock(
        "AutoAddr",
        "enable or disable automatic addressing",
        "PSeg[0] 0 disable / not 0 enable",
        "PSeg[0] status",
    ),
    FirmwareBlock(
        "Command",
        "send an AS-i command to a slave",
        "PSeg[0] slave address, PSeg[1] 5-bit information part",
        "PSeg[0] status, PSeg[1] 4-bit response",
        for_projected_slave=True,
        slave_answer=(0, 1),
    ),
    FirmwareBlock(
        "RdEeprom",
        "read the EEPROM",
        "PSeg[0] count 1..8, PSeg[1] address high, PSeg[2] address low",
        "PSeg[0..7] data",
    ),
    FirmwareBlock(
        "WrEeprom",
        "write the EEPROM",
        "PSeg[0] count 1..8, PSeg[1] address high, PSeg[2] address low, PSeg[3..10] data",
        "PSeg[0..7] data",
    ),
    FirmwareBlock("GetId", "read the firmware version ID", "none", "PSeg[0..7] version ID"),
)

#: casefolded name -> block
FIRMWARE_BLOCKS: dict[str, FirmwareBlock] = {b.name.casefold(): b for b in _BLOCKS}


class FirmwareServices(Protocol):
    """What a running program's firmware calls do: each works on the 16 PSeg bytes.

    The emulated master implements this against its AS-i bus; tests give a small
    deterministic model, the same one to the compiled code and the reference interpreter.
    """

    def call(self, name: str, pseg: bytearray) -> None: ...
