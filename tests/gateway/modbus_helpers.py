"""Raw-PDU helpers for the gateway's protocol tests (no transport in between)."""

from __future__ import annotations

import struct

from asictl.gateway.slave import GatewaySlave


class FakeClock:
    """Wall-clock stand-in so protocol tests decide when master time passes."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def request(gw: GatewaySlave, function: int, fmt: str = "", *values: int, unit: int = 1):
    """Send one PDU; the response PDU (or None)."""
    return gw.frame(unit, bytes([function]) + struct.pack(">" + fmt, *values))


def read_holding(gw: GatewaySlave, address: int, count: int = 1) -> list[int]:
    response = request(gw, 3, "HH", address, count)
    assert response is not None and response[0] == 3, response
    return list(struct.unpack(f">{count}H", response[2:]))


def read_input(gw: GatewaySlave, address: int, count: int = 1) -> list[int]:
    response = request(gw, 4, "HH", address, count)
    assert response is not None and response[0] == 4, response
    return list(struct.unpack(f">{count}H", response[2:]))


def write_holding(gw: GatewaySlave, address: int, value: int) -> None:
    response = request(gw, 6, "HH", address, value)
    assert response == struct.pack(">BHH", 6, address, value), response


def bits(gw: GatewaySlave, function: int, address: int, count: int) -> list[bool]:
    response = request(gw, function, "HH", address, count)
    assert response is not None and response[0] == function, response
    return [bool(response[2 + i // 8] >> (i % 8) & 1) for i in range(count)]


def exception(gw: GatewaySlave, function: int, fmt: str = "", *values: int) -> int:
    response = request(gw, function, fmt, *values)
    assert response is not None and len(response) == 2 and response[0] == function | 0x80
    return response[1]
