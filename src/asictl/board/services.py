"""The firmware function blocks (manual 3.8) acting on the emulated master's real state.

A running program reaches these through ``JU FB <name>``; the runtime hands over the 16
PSeg bytes. Each block does what the host command of the same meaning does (SetPP is
command 3 for one slave, Address is command 20, ...), so program and host see one master.
Status 00h is success, 80h an error; Address reports 80h plus the status byte of manual
10.2.7 (82h slave not found ... 87h).
"""

from __future__ import annotations

from collections.abc import Callable

from asictl.board.execution import ExecutionControl
from asictl.platform.master import EEPROM_SIZE
from asictl.platform.pc2 import Status
from asictl.runtime.layout import default_entry_points

#: Where this firmware's function blocks are: what command 53 reports from FF00h and
#: what a program's image must be linked against.
ENTRY_POINTS = default_entry_points()
OK = 0x00
ERROR = 0x80


class MasterFirmware:
    """``FirmwareServices`` for the board: PSeg in, PSeg out, the master changed."""

    def __init__(self, execution: ExecutionControl, eeprom: bytearray, version_id: bytes) -> None:
        self.execution = execution
        self.eeprom = eeprom
        self.version_id = version_id
        #: how many blocks were called: a cycle that called one is never skipped as idle
        self.calls = 0
        self._blocks: dict[str, Callable[[bytearray], None]] = {
            "SetPP": self._set_pp,
            "GetPP": lambda p: self._get(p, self.execution.pp),
            "SendPrm": self._send_prm,
            "GetPI": lambda p: self._get(p, self.execution.pi),
            "GetPCD": lambda p: self._get(p, self.execution.pcd),
            "GetCDI": lambda p: self._get(p, self.execution.cdi),
            "GetLPS": lambda p: self._list(p, self.execution.lps),
            "GetLAS": lambda p: self._list(p, self.execution.las),
            "GetLDS": lambda p: self._list(p, self.execution.lds),
            "DataEx": self._data_ex,
            "Address": self._address,
            "AutoAddr": self._auto_addr,
            "Command": self._command,
            "RdEeprom": self._read_eeprom,
            "WrEeprom": self._write_eeprom,
            "GetId": self._get_id,
        }

    def call(self, name: str, pseg: bytearray) -> None:
        self.calls += 1
        self._blocks[name](pseg)

    @staticmethod
    def _get(pseg: bytearray, table: bytearray) -> None:
        if pseg[0] < len(table):
            pseg[1] = table[pseg[0]]
            pseg[0] = OK
        else:
            pseg[0] = ERROR

    @staticmethod
    def _list(pseg: bytearray, mask: int) -> None:
        """Slaves 24-31 first: the reverse of the DPRAM's byte order."""
        pseg[0] = OK
        pseg[1:5] = mask.to_bytes(4, "big")

    def _set_pp(self, pseg: bytearray) -> None:
        address, parameter = pseg[0], pseg[1]
        if address >= len(self.execution.pp) or parameter > 0xF:
            pseg[0] = ERROR
            return
        pp = bytearray(self.execution.pp)
        pp[address] = parameter
        self.execution.set_permanent_parameters(bytes(pp))
        pseg[0] = OK

    def _send_prm(self, pseg: bytearray) -> None:
        if pseg[0] >= len(self.execution.pi):
            pseg[0] = ERROR
            return
        answer = self.execution.write_parameter(pseg[0], pseg[1])
        if answer is None:
            pseg[0] = ERROR
        else:
            pseg[0], pseg[1] = OK, answer

    def _data_ex(self, pseg: bytearray) -> None:
        self._host_flags(data_exchange_active=pseg[0] == 0)
        pseg[0] = OK

    def _auto_addr(self, pseg: bytearray) -> None:
        self._host_flags(auto_address_enable=pseg[0] != 0)
        pseg[0] = OK

    def _host_flags(self, **change: bool) -> None:
        ec = self.execution
        flags = {
            "data_exchange_active": ec.data_exchange_active,
            "offline": ec.offline,
            "auto_address_enable": ec.auto_address_enable,
        }
        ec.set_host_flags(**{**flags, **change})

    def _address(self, pseg: bytearray) -> None:
        status = self.execution.change_slave_address(pseg[0], pseg[1])
        pseg[0] = OK if status is Status.OK else ERROR | status

    def _command(self, pseg: bytearray) -> None:
        answer = self.execution.execute_command(pseg[0], pseg[1])
        if answer is None:
            pseg[0] = ERROR
        else:
            pseg[0], pseg[1] = OK, answer

    def _eeprom_range(self, pseg: bytearray) -> range | None:
        """Count 1..8 at address PSeg[1]:PSeg[2]; out of range: the block does nothing."""
        count, address = pseg[0], pseg[1] << 8 | pseg[2]
        if not 1 <= count <= 8 or address + count > EEPROM_SIZE:
            return None
        return range(address, address + count)

    def _read_eeprom(self, pseg: bytearray) -> None:
        where = self._eeprom_range(pseg)
        if where is not None:
            pseg[: len(where)] = self.eeprom[where.start : where.stop]

    def _write_eeprom(self, pseg: bytearray) -> None:
        where = self._eeprom_range(pseg)
        if where is not None:
            data = pseg[3 : 3 + len(where)]
            self.eeprom[where.start : where.stop] = data
            pseg[: len(where)] = data

    def _get_id(self, pseg: bytearray) -> None:
        pseg[:8] = self.version_id
