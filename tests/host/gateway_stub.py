"""A stand-in gateway for the transport tests until the emulated gateway server exists.

It answers the register functions the transport uses (3, 6, 16, 7) from the gateway
engineer's ``AddressMap`` and 65/66/67 through ``server_pdus``, all over one ``Pc2Board``,
so a test can download over Modbus and upload over the PC2 port of the same master.
``faults`` lets a test drop or corrupt chosen responses to exercise the retries.
"""

from __future__ import annotations

import asyncio
import socket
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from pymodbus import FramerType
from pymodbus.pdu import ModbusPDU
from pymodbus.pdu.other_message import ReadExceptionStatusRequest, ReadExceptionStatusResponse
from pymodbus.pdu.register_message import (
    ReadHoldingRegistersRequest,
    ReadHoldingRegistersResponse,
    WriteMultipleRegistersRequest,
    WriteMultipleRegistersResponse,
    WriteSingleRegisterRequest,
    WriteSingleRegisterResponse,
)
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from asictl.board.board import Pc2Board
from asictl.gateway.addressmap import AddressMap
from asictl.host.transfer import Pc2Transport
from asictl.host.transports.gateway_pdus import BLOCK_SIZE, server_pdus


class StubHandler:
    """Functions 65/66/67 over the board's own download/upload commands (52/53)."""

    def __init__(self, board: Pc2Board) -> None:
        self.map = AddressMap(board)
        self.pc2 = Pc2Transport(self.map.driver)

    def master_info(self, part: int) -> str:
        return {1: "stub gateway", 3: self.map.installed_software()}.get(part, "1.0")

    def write_program(self, address: int, data: bytes) -> None:
        self.pc2.write_eeprom(address, data)

    def read_program(self, address: int) -> bytes:
        return self.pc2.read_eeprom(address, BLOCK_SIZE)


def _register_pdus(gateway: AddressMap) -> list[type[ModbusPDU]]:
    def reply(request: ModbusPDU, response: ModbusPDU, device_id: int) -> ModbusPDU:
        response.dev_id, response.transaction_id = device_id, request.transaction_id
        return response

    class Read(ReadHoldingRegistersRequest):
        async def datastore_update(self, context, device_id: int) -> ModbusPDU:
            values = gateway.read_holding_registers(self.address, self.count)
            return reply(self, ReadHoldingRegistersResponse(registers=values), device_id)

    class WriteOne(WriteSingleRegisterRequest):
        async def datastore_update(self, context, device_id: int) -> ModbusPDU:
            gateway.write_registers(self.address, list(self.registers))
            return reply(
                self, WriteSingleRegisterResponse(address=self.address, registers=self.registers),
                device_id,
            )

    class WriteMany(WriteMultipleRegistersRequest):
        async def datastore_update(self, context, device_id: int) -> ModbusPDU:
            gateway.write_registers(self.address, list(self.registers))
            return reply(
                self, WriteMultipleRegistersResponse(address=self.address, count=self.count),
                device_id,
            )

    class Status(ReadExceptionStatusRequest):
        async def datastore_update(self, context, device_id: int) -> ModbusPDU:
            return reply(
                self, ReadExceptionStatusResponse(status=gateway.exception_status()), device_id
            )

    return [Read, WriteOne, WriteMany, Status]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextmanager
def stub_gateway(
    board: Pc2Board, *, rtu: bool = False,
    faults: Callable[[bytes], bytes] | None = None,
) -> Iterator[str]:
    """Serve ``board`` on loopback; yields the ``--modbus`` URL. ``faults`` sees each
    response frame and returns what is really sent (b"" sends nothing)."""
    handler = StubHandler(board)
    port = free_port()
    ready = threading.Event()
    holder: dict = {}

    def trace(sending: bool, data: bytes) -> bytes:
        return faults(data) if sending and faults else data

    async def serve() -> None:
        device = SimDevice(id=0, simdata=[SimData(0, count=1, datatype=DataType.REGISTERS)])
        server = ModbusTcpServer(
            device, address=("127.0.0.1", port),
            framer=FramerType.RTU if rtu else FramerType.SOCKET,
            custom_pdu=server_pdus(handler) + _register_pdus(handler.map),
            trace_packet=trace,
        )
        holder["server"], holder["loop"] = server, asyncio.get_running_loop()
        await server.serve_forever(background=True)
        ready.set()
        await server.serving

    thread = threading.Thread(target=lambda: asyncio.run(serve()), daemon=True)
    thread.start()
    assert ready.wait(5), "stub gateway did not start"
    try:
        yield f"{'rtu+tcp' if rtu else 'tcp'}://127.0.0.1:{port}"
    finally:
        asyncio.run_coroutine_threadsafe(holder["server"].shutdown(), holder["loop"]).result(5)
        thread.join(5)
