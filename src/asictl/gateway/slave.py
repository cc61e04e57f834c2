"""The gateway's Modbus slave: one PDU in, one PDU (or silence) out, with the counters.

Transport-free on purpose: TCP and RTU (server.py) hand every frame they see here, so the
diagnostics counters of function 8, listen-only mode, broadcast and the watchdog behave the
same on both, and tests can drive the protocol without a socket. pymodbus's own server is
not used for this part: its RTU framer silently drops frames with a bad CRC or an unknown
function code (no CRC counter, no "illegal function" answer) and it has no listen-only mode,
all of which the gateway manual requires (6.3.11).

The user-defined functions 65, 66 and 67 are decoded and encoded by the PDU classes of
``host.transports.gateway_pdus``, the very classes our Modbus client uses, so both ends
share one wire format.
"""

from __future__ import annotations

import struct
import time
from collections.abc import Callable
from dataclasses import dataclass, fields, replace

from pymodbus.pdu import ModbusPDU
from pymodbus.pdu.other_message import ReportDeviceIdResponse

from asictl.board.board import Pc2Board
from asictl.gateway.addressmap import MAX_BITS, AddressMap, ExceptionCode, ModbusError
from asictl.gateway.panel import FrontPanel
from asictl.gateway.requestlog import request_line
from asictl.host.transports import gateway_pdus as pdus
from asictl.platform import pc2 as d
from asictl.platform.gateway import UNITS, Interface
from asictl.platform.master import EEPROM_SIZE
from asictl.platform.pc2 import EMULATION_MARK, Command

#: The gateway's own name (function 65, P = 1: at most 32 characters, gateway manual
#: 6.3.12); version and ID come from the master.
GATEWAY_NAME = "VAG-MOD-KF-R4 AS-i/Modbus"
#: Function 17 (Report Slave ID), which the real gateway does not have (manual 6.3.9:
#: "nicht belegt"): the emulation answers it to identify itself (host/overwrite_guard.py).
SERVER_ID = f"{GATEWAY_NAME}, {EMULATION_MARK}"
BROADCAST = 0
#: Functions a broadcast executes (they write; reads make no sense without an answer).
BROADCAST_FUNCTIONS = frozenset({5, 6, 15, 16, pdus.FC_DOWNLOAD})
#: Master time one request may catch up with the wall clock at most (after a stall).
MAX_CATCH_UP_MS = 1000.0


class Diagnostic:
    """Function 8 sub-function codes the gateway accepts (manual 6.3.11)."""

    RETURN_QUERY_DATA = 0
    RESTART_COMMUNICATIONS = 1
    DIAGNOSTIC_REGISTER = 2
    FORCE_LISTEN_ONLY = 4
    CLEAR_COUNTERS = 10
    #: 11..18: the counters, in the order of ``Counters``' fields
    FIRST_COUNTER = 11


@dataclass
class Counters:
    """Function 8's counters 11..18 (the last three always stay 0, as on the gateway)."""

    bus_messages: int = 0
    crc_errors: int = 0
    exceptions: int = 0
    slave_messages: int = 0
    no_responses: int = 0
    naks: int = 0
    busy: int = 0
    overruns: int = 0

    def clear(self) -> None:
        for f in fields(self):
            setattr(self, f.name, 0)

    def by_code(self, code: int) -> int:
        count: int = getattr(self, fields(self)[code - Diagnostic.FIRST_COUNTER].name)
        return count & 0xFFFF


def _unpack(fmt: str, data: bytes) -> tuple[int, ...]:
    """Fixed-size request fields; any other length is a malformed telegram (exception 3)."""
    if len(data) != struct.calcsize(fmt):
        raise ModbusError(ExceptionCode.ILLEGAL_DATA_VALUE, "telegram of the wrong length")
    return struct.unpack(fmt, data)


def _pack_bits(values: list[bool]) -> bytes:
    out = bytearray((len(values) + 7) // 8)
    for i, on in enumerate(values):
        out[i // 8] |= on << (i % 8)
    return bytes([len(out)]) + bytes(out)


class GatewaySlave:
    """The Modbus slave of one gateway over one master; not thread-safe (one event loop)."""

    def __init__(
        self, board: Pc2Board, unit: int = 1, clock: Callable[[], float] = time.monotonic,
        *, sync: Callable[[], None] | None = None, interface: Interface | None = None,
    ) -> None:
        if unit not in UNITS:
            raise ValueError(f"the gateway's Modbus address is {UNITS[0]}..{UNITS[-1]}, not {unit}")
        self.board = board
        self.map = AddressMap(board)
        self.unit = unit
        #: the front panel; its keys can give the gateway another Modbus address (5.6)
        self.panel = FrontPanel(board, self.map, replace(interface or Interface(), unit=unit))
        self.panel.on_interface.append(self._interface_set)
        self.listen_only = False
        self.counters = Counters()
        #: told one line per frame (``gateway serve --verbose``)
        self.request_log: Callable[[str], None] | None = None
        self._clock = clock
        self._synced = clock()
        #: who keeps master time with the wall clock instead (a live board: ``host.live``)
        self._sync = sync
        self._last_telegram: float | None = None
        self._functions: dict[int, Callable[[bytes], bytes | None]] = {
            1: self._read_coils,
            2: self._read_inputs,
            3: self._read_holding,
            4: self._read_input_registers,
            5: self._write_coil,
            6: self._write_register,
            7: self._exception_status,
            8: self._diagnostics,
            15: self._write_coils,
            16: self._write_registers,
            17: self._report_server_id,
            pdus.FC_INFO: self._master_info,
            pdus.FC_DOWNLOAD: self._download,
            pdus.FC_UPLOAD: self._upload,
        }

    # ------------------------------------------------------------------ time

    def sync(self) -> None:
        """Let master time catch up with the wall clock (at most ``MAX_CATCH_UP_MS``).

        The gateway is live: the master's cycles, program and watchdog run while nobody
        asks. Transports call this before each request and from a periodic timer.
        """
        if self._sync is not None:
            self._sync()
        else:
            now = self._clock()
            elapsed_ms = (now - self._synced) * 1000
            self._synced = now
            if elapsed_ms > 0:
                self.board.advance(min(elapsed_ms, MAX_CATCH_UP_MS))
        self.panel.tick()

    def _interface_set(self, interface: Interface) -> None:
        """The keys stored a Modbus address: from now on the gateway answers to it."""
        self.unit = interface.unit

    # ------------------------------------------------------------------ frames

    def frame(self, unit: int, pdu: bytes, *, crc_ok: bool = True) -> bytes | None:
        """A frame seen on the bus; the response PDU, or None when the gateway stays silent."""
        response = self._frame(unit, pdu, crc_ok=crc_ok)
        if self.request_log is not None:
            self.request_log(request_line(
                unit, pdu, response, own_unit=self.unit, crc_ok=crc_ok,
                listen_only=self.listen_only,
            ))
        return response

    def _frame(self, unit: int, pdu: bytes, *, crc_ok: bool) -> bytes | None:
        c = self.counters
        c.bus_messages += 1
        if self.panel.in_menu:
            return None  # "Kommunikation über den Modbus nicht möglich" (gateway manual 5.6)
        if unit not in (self.unit, BROADCAST):
            return None
        if not crc_ok:
            c.crc_errors += 1
            c.no_responses += 1
            return None
        c.slave_messages += 1
        self.sync()
        now = self._clock()
        pause_ms = 0.0 if self._last_telegram is None else (now - self._last_telegram) * 1000
        self._last_telegram = now
        self.map.feed_watchdog(pause_ms)
        if self.listen_only:
            if pdu[:3] == bytes([8, 0, Diagnostic.RESTART_COMMUNICATIONS]) and len(pdu) == 5:
                self._restart(pdu[3:])
            c.no_responses += 1
            return None
        self.panel.telegram()
        response = self._execute(pdu, broadcast=unit == BROADCAST)
        if response is None or unit == BROADCAST:
            c.no_responses += 1
            return None
        if response[0] & 0x80:
            c.exceptions += 1
        return response

    def _execute(self, pdu: bytes, *, broadcast: bool) -> bytes | None:
        if not pdu:
            return None
        code = pdu[0]
        if broadcast and code not in BROADCAST_FUNCTIONS:
            return None
        handler = self._functions.get(code)
        try:
            if handler is None:
                raise ModbusError(ExceptionCode.ILLEGAL_FUNCTION, f"no function {code}")
            data = handler(pdu[1:])
        except ModbusError as exc:
            return bytes([code | 0x80, exc.code])
        return None if data is None else bytes([code]) + data

    # ------------------------------------------------------------------ standard functions

    def _read_coils(self, data: bytes) -> bytes:
        return _pack_bits(self.map.read_coils(*_unpack(">HH", data)))

    def _read_inputs(self, data: bytes) -> bytes:
        return _pack_bits(self.map.read_discrete_inputs(*_unpack(">HH", data)))

    def _registers(self, values: list[int]) -> bytes:
        return bytes([2 * len(values)]) + struct.pack(f">{len(values)}H", *values)

    def _read_holding(self, data: bytes) -> bytes:
        return self._registers(self.map.read_holding_registers(*_unpack(">HH", data)))

    def _read_input_registers(self, data: bytes) -> bytes:
        return self._registers(self.map.read_input_registers(*_unpack(">HH", data)))

    def _write_coil(self, data: bytes) -> bytes:
        address, value = _unpack(">HH", data)
        if value not in (0x0000, 0xFF00):
            raise ModbusError(ExceptionCode.ILLEGAL_DATA_VALUE, "a coil is 0000h or FF00h")
        self.map.write_coils(address, [value == 0xFF00])
        return data

    def _write_register(self, data: bytes) -> bytes:
        address, value = _unpack(">HH", data)
        self.map.write_registers(address, [value])
        return data

    def _write_coils(self, data: bytes) -> bytes:
        address, count, size = _unpack(">HHB", data[:5])
        if not 1 <= count <= MAX_BITS or size != (count + 7) // 8 or len(data) != 5 + size:
            raise ModbusError(ExceptionCode.ILLEGAL_DATA_VALUE, "coil count and byte count")
        bits = [bool(data[5 + i // 8] >> (i % 8) & 1) for i in range(count)]
        self.map.write_coils(address, bits)
        return data[:4]

    def _write_registers(self, data: bytes) -> bytes:
        address, count, size = _unpack(">HHB", data[:5])
        if size != 2 * count or len(data) != 5 + size:
            raise ModbusError(ExceptionCode.ILLEGAL_DATA_VALUE, "register count and byte count")
        self.map.write_registers(address, list(struct.unpack(f">{count}H", data[5:])))
        return data[:4]

    def _report_server_id(self, data: bytes) -> bytes:
        _unpack("", data)
        return ReportDeviceIdResponse(identifier=SERVER_ID.encode("ascii")).encode()

    def _exception_status(self, data: bytes) -> bytes:
        _unpack("", data)
        return bytes([self.map.exception_status()])

    # ------------------------------------------------------------------ diagnostics

    def _diagnostics(self, data: bytes) -> bytes | None:
        if len(data) < 2:
            raise ModbusError(ExceptionCode.ILLEGAL_DATA_VALUE, "no diagnostic code")
        (code,) = struct.unpack(">H", data[:2])
        if code == Diagnostic.RETURN_QUERY_DATA:
            return data
        (value,) = _unpack(">H", data[2:])
        if code == Diagnostic.RESTART_COMMUNICATIONS:
            if value not in (0x0000, 0xFF00):
                raise ModbusError(ExceptionCode.ILLEGAL_DATA_VALUE, "restart takes 0000h/FF00h")
            self._restart(data[2:])
            return data
        if value:
            raise ModbusError(ExceptionCode.ILLEGAL_DATA_VALUE, "this diagnostic takes 0000h")
        if code == Diagnostic.DIAGNOSTIC_REGISTER:
            return data[:2] + struct.pack(">H", self.map.diagnostic_register())
        if code == Diagnostic.FORCE_LISTEN_ONLY:
            self.listen_only = True
            return None
        if code == Diagnostic.CLEAR_COUNTERS:
            self.counters.clear()
            return data
        if Diagnostic.FIRST_COUNTER <= code < Diagnostic.FIRST_COUNTER + len(fields(Counters)):
            return data[:2] + struct.pack(">H", self.counters.by_code(code))
        raise ModbusError(ExceptionCode.ILLEGAL_FUNCTION, f"no diagnostic code {code}")

    def _restart(self, value: bytes) -> None:
        """Listen-only off, counters cleared, watchdog off, master through the offline phase."""
        if value not in (b"\x00\x00", b"\xff\x00"):
            return
        self.listen_only = False
        self.counters.clear()
        self.map.restart_master()

    # ------------------------------------------------------------------ 65, 66, 67

    def _decode(self, request: ModbusPDU, data: bytes) -> None:
        try:
            request.decode(data)
        except ValueError as exc:
            raise ModbusError(ExceptionCode.ILLEGAL_DATA_VALUE, str(exc)) from None

    def _master_info(self, data: bytes) -> bytes:
        request = pdus.MasterInfoRequest()
        self._decode(request, data)
        return pdus.MasterInfoResponse(self.master_info(request.part), request.part).encode()

    def master_info(self, part: int) -> str:
        """Function 65: the gateway's name, else the master's version strings and letters."""
        ram = self.board.dpram
        if part == pdus.INFO_NAME:
            return GATEWAY_NAME
        if part == pdus.INFO_VERSION:
            start = d.MASTER_NAME + 32
            return ram[start : start + 16].split(b"\0")[0].decode("ascii")
        if part == pdus.INFO_SOFTWARE:
            return self.map.installed_software()
        return ram[d.VERSION_ID : d.VERSION_ID + d.VERSION_ID_SIZE].decode("ascii")

    def _block_address(self, address: int, *, upload: bool) -> None:
        inside = address + pdus.BLOCK_SIZE <= EEPROM_SIZE or (
            upload
            and address >= d.ENTRY_TABLE_ADDRESS
            and address + pdus.BLOCK_SIZE <= d.ENTRY_TABLE_ADDRESS + d.ENTRY_TABLE_SIZE
        )
        if not inside:
            raise ModbusError(
                ExceptionCode.ILLEGAL_DATA_ADDRESS, f"program address {address:04X}h"
            )

    def _download(self, data: bytes) -> bytes:
        """Function 66 is command 52: the same EEPROM a PC2-port upload reads back."""
        request = pdus.DownloadRequest()
        self._decode(request, data)
        self._block_address(request.address, upload=False)
        self.map.driver.write(d.PROGRAM_BUFFER, request.data)
        ok, _ = self.map.command(
            Command.DOWNLOAD, pdus.BLOCK_SIZE, request.address & 0xFF, request.address >> 8
        )
        if not ok:
            raise ModbusError(ExceptionCode.SLAVE_DEVICE_FAILURE, "the master refused 52")
        return pdus.DownloadResponse(address=request.address).encode()

    def _upload(self, data: bytes) -> bytes:
        """Function 67 is command 53 (from FF00h: the firmware's entry table, as on the PC2)."""
        request = pdus.UploadRequest()
        self._decode(request, data)
        self._block_address(request.address, upload=True)
        ok, _ = self.map.command(
            Command.UPLOAD, pdus.BLOCK_SIZE, request.address & 0xFF, request.address >> 8
        )
        if not ok:
            raise ModbusError(ExceptionCode.SLAVE_DEVICE_FAILURE, "the master refused 53")
        block = self.map.driver.read(d.PROGRAM_BUFFER, pdus.BLOCK_SIZE)
        return pdus.UploadResponse(address=request.address, data=block).encode()
