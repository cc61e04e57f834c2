"""One line per Modbus request the gateway sees, for ``gateway serve --verbose``.

What an integrator debugging a Modbus master needs: which unit a frame was for, the
function, address and quantity (or value) it asked for, and what came of it: the answer,
an exception with its code, or silence and why (another unit, a CRC error, a broadcast,
listen-only mode).
"""

from __future__ import annotations

import struct
import time

from asictl.gateway.addressmap import ExceptionCode
from asictl.host.transports import gateway_pdus as pdus

FUNCTION_NAMES = {
    1: "read coils",
    2: "read discrete inputs",
    3: "read holding registers",
    4: "read input registers",
    5: "write single coil",
    6: "write single register",
    7: "read exception status",
    8: "diagnostics",
    15: "write multiple coils",
    16: "write multiple registers",
    pdus.FC_INFO: "master info",
    pdus.FC_DOWNLOAD: "EEPROM write",
    pdus.FC_UPLOAD: "EEPROM read",
}
_ADDRESS_QUANTITY = frozenset({1, 2, 3, 4, 15, 16})
_ADDRESS_VALUE = frozenset({5, 6})
#: The manual's five-digit numbering: table digit, then the register or bit number from 1
#: (PDU address 1000 of a holding register is its "41001").
_TABLE = {1: 0, 5: 0, 15: 0, 2: 1, 4: 3, 3: 4, 6: 4, 16: 4}


def _address(code: int, address: int) -> str:
    return f"address {address} ({_TABLE[code]}{address + 1:04d})"


def _fields(code: int, data: bytes) -> str:
    """The request's parameters, as far as the telegram is long enough to hold them."""
    if code in _ADDRESS_QUANTITY and len(data) >= 4:
        address, quantity = struct.unpack(">HH", data[:4])
        return f" {_address(code, address)} quantity {quantity}"
    if code in _ADDRESS_VALUE and len(data) >= 4:
        address, value = struct.unpack(">HH", data[:4])
        return f" {_address(code, address)} value {value:04X}h"
    if code == 8 and len(data) >= 2:
        return f" sub-function {struct.unpack('>H', data[:2])[0]}"
    if code in (pdus.FC_DOWNLOAD, pdus.FC_UPLOAD) and len(data) >= 3:
        return f" address {struct.unpack('>H', data[1:3])[0]:04X}h quantity {pdus.BLOCK_SIZE}"
    if code == pdus.FC_INFO and len(data) >= 2:
        return f" part {data[1]}"
    return ""


def _outcome(response: bytes | None, *, crc_ok: bool, broadcast: bool, listen_only: bool) -> str:
    if not crc_ok:
        return "no answer (CRC error)"
    if response is not None and len(response) >= 2 and response[0] & 0x80:
        try:
            name = ExceptionCode(response[1]).name.lower().replace("_", " ")
        except ValueError:
            name = "unknown"
        return f"exception {response[1]} ({name})"
    if response is not None:
        return "ok"
    if broadcast:
        return "no answer (broadcast)"
    if listen_only:
        return "no answer (listen-only mode)"
    return "no answer"


def request_line(
    unit: int, pdu: bytes, response: bytes | None, *, own_unit: int, crc_ok: bool = True,
    listen_only: bool = False, now: float | None = None,
) -> str:
    """The log line of one frame: time, unit, function and its fields, outcome."""
    if now is None:  # one reading: seconds and milliseconds of the same instant
        now = time.time()
    stamp = time.strftime("%H:%M:%S", time.localtime(now)) + f".{int(now * 1000) % 1000:03d}"
    head = f"{stamp} unit {unit}"
    if not pdu:
        return f"{head} empty frame -> " + ("no answer (CRC error)" if not crc_ok else "ignored")
    code = pdu[0]
    name = FUNCTION_NAMES.get(code, "unknown function")
    text = f"{head} fc {code} ({name}){_fields(code, pdu[1:])} -> "
    if unit not in (own_unit, 0):
        return text + f"ignored (this gateway is unit {own_unit})"
    return text + _outcome(
        response, crc_ok=crc_ok, broadcast=unit == 0, listen_only=listen_only
    )
