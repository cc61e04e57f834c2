"""``--modbus URL|DEVICE``: where a gateway is, parsed without importing pymodbus.

pymodbus is an optional extra (``asictl[modbus]``); the CLI builds its options and checks
what the user wrote from this module, and loads the transport only for a --modbus command.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from asictl.errors import UserError

BAUD_RATES = (1200, 2400, 4800, 9600, 19200, 38400, 57600)
PARITIES = {"none": "N", "even": "E", "odd": "O"}
DEFAULT_TCP_PORT = 502
DEFAULT_TIMEOUT_S = 1.0
DEFAULT_RETRIES = 3


@dataclass(frozen=True)
class ModbusTarget:
    """Where the gateway is: ``tcp://HOST[:PORT]`` (Modbus TCP), ``rtu+tcp://HOST[:PORT]``
    (RTU frames through a serial-device server) or a serial device (RTU, as the gateway
    itself speaks it)."""

    spec: str
    host: str | None = None
    port: int = DEFAULT_TCP_PORT
    rtu: bool = True
    device: str | None = None
    baud: int = 9600
    parity: str = "none"
    stopbits: int = 1

    def __str__(self) -> str:
        return self.spec


_URL = re.compile(
    r"(?P<scheme>tcp|rtu\+tcp)://(?P<host>\[[^\]]+\]|[^:/]+)(?::(?P<port>[^/]*))?/?"
)


def port_number(text: str) -> int | None:
    """A TCP port as written: 1 to 5 ASCII digits, 0..65535; None for anything else
    (``str.isdigit`` and ``int`` take '²' and 5000-digit numbers, which are no ports)."""
    if not re.fullmatch(r"[0-9]{1,5}", text):
        return None
    number = int(text)
    return number if number <= 65535 else None


def parse_target(
    spec: str, *, baud: int = 9600, parity: str = "none", stopbits: int = 1
) -> ModbusTarget:
    """``--modbus`` as the user wrote it; a URL with another scheme is refused, not tried."""
    if "://" not in spec:
        return ModbusTarget(spec, device=spec, baud=baud, parity=parity, stopbits=stopbits)
    match = _URL.fullmatch(spec)
    port = DEFAULT_TCP_PORT if match and match["port"] is None else (
        port_number(match["port"]) if match else None
    )
    if not match or not port:
        shown = spec if len(spec) <= 60 else f"{spec[:57]}..."
        raise UserError(
            f"--modbus '{shown}': expected tcp://HOST[:PORT], rtu+tcp://HOST[:PORT] or a "
            "serial device such as /dev/ttyUSB0"
        )
    return ModbusTarget(
        spec, host=match["host"].strip("[]"), port=port,
        rtu=match["scheme"] == "rtu+tcp",
    )
