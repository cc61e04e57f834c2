"""The gateway's user-defined Modbus functions 65, 66 and 67 as pymodbus PDUs.

Chapter 6.3.12-6.3.14 of the VAG-MOD-KF-R4 manual defines three telegrams outside the Modbus
standard. Every one carries a byte count right after the function code, so a single
``rtu_byte_count_pos`` lets the RTU framer find the end of both query and response:

====  =================================  ===================================
 F    query (after A F)                  response (after A F)
====  =================================  ===================================
 65   1, P                               B, D1..DB (NUL-terminated ASCII)
 66   18, S_hi, S_lo, D1..D16            2, S_hi, S_lo
 67   2, S_hi, S_lo                      18, S_hi, S_lo, D1..D16
====  =================================  ===================================

The figure with the query of function 65 was lost in the manual's extraction; the query here
follows the byte-count convention of 66 and 67 (``1, P``), the response is as printed.

Both sides share these classes. A client registers :data:`CLIENT_PDUS` (the responses) with
``client.register``; a server passes ``server_pdus(handler)`` (requests bound to its emulated
master) as ``custom_pdu=``. pymodbus decodes a registered class both ways, which is why requests
and responses are separate classes and each side registers only the half it receives.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Protocol

from pymodbus.constants import ExcCodes
from pymodbus.datastore import ModbusServerContext
from pymodbus.pdu import ExceptionResponse, ModbusPDU

__all__ = [
    "BLOCK_SIZE",
    "CLIENT_PDUS",
    "FC_DOWNLOAD",
    "FC_INFO",
    "FC_UPLOAD",
    "INFO_NAME",
    "INFO_SOFTWARE",
    "INFO_VERSION",
    "INFO_VERSION_ID",
    "DownloadRequest",
    "DownloadResponse",
    "GatewayFunctionError",
    "MasterInfoRequest",
    "MasterInfoResponse",
    "UploadRequest",
    "UploadResponse",
    "UserFunctionHandler",
    "info_width",
    "server_pdus",
]

FC_INFO = 65
FC_DOWNLOAD = 66
FC_UPLOAD = 67

#: Program bytes carried by one function 66 or 67 telegram.
BLOCK_SIZE = 16

#: Values of P in function 65 (any other value reads the version ID).
INFO_NAME = 1
INFO_VERSION = 2
INFO_SOFTWARE = 3
INFO_VERSION_ID = 0

_INFO_WIDTHS = {INFO_NAME: 32, INFO_VERSION: 16, INFO_SOFTWARE: 32}
_VERSION_ID_WIDTH = 8
_ADDRESS = struct.Struct(">H")


def info_width(part: int) -> int:
    """Characters of the answer to function 65 for part ``part``, without the NUL."""
    return _INFO_WIDTHS.get(part, _VERSION_ID_WIDTH)


class GatewayFunctionError(Exception):
    """Raised by a :class:`UserFunctionHandler` to answer with a Modbus exception telegram.

    The server turns any other exception into "device failure"; this one lets the emulated
    master say precisely why it refuses (an illegal address, a busy master, ...).
    """

    def __init__(self, exception_code: int, message: str = "") -> None:
        super().__init__(message or f"Modbus exception {exception_code}")
        self.exception_code = exception_code


class UserFunctionHandler(Protocol):
    """What a server must provide to answer functions 65, 66 and 67."""

    def master_info(self, part: int) -> str:
        """The text function 65 returns for ``part``; it is cut or padded to the fixed width."""

    def write_program(self, address: int, data: bytes) -> None:
        """Store 16 control-program bytes at ``address`` (function 66)."""

    def read_program(self, address: int) -> bytes:
        """Return the 16 control-program bytes at ``address`` (function 67)."""


def _expect(condition: bool, what: str) -> None:
    """Reject a malformed telegram; pymodbus' decoder treats ValueError as a bad frame."""
    if not condition:
        raise ValueError(f"malformed telegram: {what}")


class _UserFunctionPDU(ModbusPDU):
    """Common framing: the byte count is the third byte of the RTU frame (after A and F)."""

    rtu_byte_count_pos = 2


class MasterInfoRequest(_UserFunctionPDU):
    """Function 65 query: which part of the name/version information to read."""

    function_code = FC_INFO

    def __init__(self, part: int = INFO_NAME, dev_id: int = 0, transaction_id: int = 0) -> None:
        super().__init__(dev_id=dev_id, transaction_id=transaction_id)
        self.part = part

    def encode(self) -> bytes:
        return bytes((1, self.part & 0xFF))

    def decode(self, data: bytes) -> None:
        _expect(len(data) == 2 and data[0] == 1, "function 65 query needs byte count 1 and P")
        self.part = data[1]


class MasterInfoResponse(_UserFunctionPDU):
    """Function 65 response: a NUL-terminated ASCII string of a fixed width per part."""

    function_code = FC_INFO

    def __init__(
        self, text: str = "", part: int = INFO_NAME, dev_id: int = 0, transaction_id: int = 0
    ) -> None:
        super().__init__(dev_id=dev_id, transaction_id=transaction_id)
        self.text = text
        self.part = part

    def encode(self) -> bytes:
        width = info_width(self.part)
        raw = self.text.encode("ascii", "replace")[:width].ljust(width, b"\0") + b"\0"
        return bytes((len(raw),)) + raw

    def decode(self, data: bytes) -> None:
        _expect(len(data) >= 1 and len(data) == data[0] + 1, "function 65 byte count")
        self.text = data[1:].split(b"\0", 1)[0].decode("ascii", "replace")


class _BlockPDU(_UserFunctionPDU):
    """An address and 16 program bytes: the query of 66 and the response of 67."""

    def __init__(
        self, address: int = 0, data: bytes = bytes(BLOCK_SIZE), dev_id: int = 0,
        transaction_id: int = 0,
    ) -> None:
        super().__init__(dev_id=dev_id, transaction_id=transaction_id, address=address)
        if len(data) != BLOCK_SIZE:
            raise ValueError(
                f"function {self.function_code} carries exactly {BLOCK_SIZE} bytes, "
                f"not {len(data)}"
            )
        self.data = bytes(data)

    def encode(self) -> bytes:
        return bytes((2 + BLOCK_SIZE,)) + _ADDRESS.pack(self.address) + self.data

    def decode(self, data: bytes) -> None:
        _expect(
            len(data) == 3 + BLOCK_SIZE and data[0] == 2 + BLOCK_SIZE,
            f"function {self.function_code} block",
        )
        (self.address,) = _ADDRESS.unpack_from(data, 1)
        self.data = bytes(data[3:])


class DownloadRequest(_BlockPDU):
    """Function 66 query: write 16 program bytes starting at ``address``."""

    function_code = FC_DOWNLOAD


class DownloadResponse(_UserFunctionPDU):
    """Function 66 response: echoes the address of the block written."""

    function_code = FC_DOWNLOAD

    def encode(self) -> bytes:
        return b"\x02" + _ADDRESS.pack(self.address)

    def decode(self, data: bytes) -> None:
        _expect(len(data) == 3 and data[0] == 2, "function 66 response")
        (self.address,) = _ADDRESS.unpack_from(data, 1)


class UploadRequest(_UserFunctionPDU):
    """Function 67 query: read 16 program bytes starting at ``address``."""

    function_code = FC_UPLOAD

    def encode(self) -> bytes:
        return b"\x02" + _ADDRESS.pack(self.address)

    def decode(self, data: bytes) -> None:
        _expect(len(data) == 3 and data[0] == 2, "function 67 query")
        (self.address,) = _ADDRESS.unpack_from(data, 1)


class UploadResponse(_BlockPDU):
    """Function 67 response: the address echoed and the 16 bytes read."""

    function_code = FC_UPLOAD


#: The response classes a client registers (``client.register(cls)``) to decode 65, 66 and 67.
CLIENT_PDUS: tuple[type[ModbusPDU], ...] = (MasterInfoResponse, DownloadResponse, UploadResponse)


def _answer(request: ModbusPDU, device_id: int, compute: Callable[[], ModbusPDU]) -> ModbusPDU:
    """Run the handler; a GatewayFunctionError becomes the exception telegram it names."""
    try:
        response = compute()
    except GatewayFunctionError as exc:
        return ExceptionResponse(
            request.function_code, exc.exception_code, device_id, request.transaction_id
        )
    response.dev_id = device_id
    response.transaction_id = request.transaction_id
    return response


def server_pdus(handler: UserFunctionHandler) -> list[type[ModbusPDU]]:
    """Request classes bound to ``handler``, for ``custom_pdu=`` of a pymodbus server.

    pymodbus hands ``datastore_update`` only its own datastore context, which knows nothing of
    an emulated master; binding the handler into fresh subclasses lets each server instance
    answer from its own master without globals.
    """

    class BoundMasterInfoRequest(MasterInfoRequest):
        async def datastore_update(
            self, context: ModbusServerContext, device_id: int
        ) -> ModbusPDU:
            return _answer(
                self, device_id,
                lambda: MasterInfoResponse(handler.master_info(self.part), self.part),
            )

    class BoundDownloadRequest(DownloadRequest):
        async def datastore_update(
            self, context: ModbusServerContext, device_id: int
        ) -> ModbusPDU:
            def write() -> ModbusPDU:
                handler.write_program(self.address, self.data)
                return DownloadResponse(address=self.address)

            return _answer(self, device_id, write)

    class BoundUploadRequest(UploadRequest):
        async def datastore_update(
            self, context: ModbusServerContext, device_id: int
        ) -> ModbusPDU:
            def read() -> ModbusPDU:
                data = handler.read_program(self.address)
                if len(data) != BLOCK_SIZE:
                    raise GatewayFunctionError(ExcCodes.DEVICE_FAILURE, "short program block")
                return UploadResponse(address=self.address, data=data)

            return _answer(self, device_id, read)

    return [BoundMasterInfoRequest, BoundDownloadRequest, BoundUploadRequest]
