"""``--modbus URL|DEVICE``: where a gateway is, parsed without importing pymodbus.

pymodbus is an optional extra (``modbus``); the CLI builds its options and checks
what the user wrote from this module, and loads the transport only for a --modbus command.
"""

from __future__ import annotations

import ipaddress
import re
from dataclasses import dataclass

from asictl.errors import ExitCode, UserError
from asictl.platform.gateway import BAUD_RATES, FRAMINGS, serial_setting_code

#: The parity as pyserial and the gateway manual write it ("N", "E", "O"), by its long
#: name; the short form is accepted too. Both spellings are case-insensitive.
PARITY_NAMES = {"none": "N", "even": "E", "odd": "O"}
#: What ``--parity`` accepts (in this order in help texts).
PARITY_SPELLINGS = (*PARITY_NAMES, *PARITY_NAMES.values())
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
    #: "N", "E" or "O" (``parity_code``)
    parity: str = "N"
    stopbits: int = 1
    #: whether the URL named the port (else it is Modbus/TCP's 502)
    port_given: bool = True

    def __str__(self) -> str:
        return self.spec

    def described(self) -> str:
        """The spec, with the port it means where the user left it out."""
        if self.host is None or self.port_given:
            return self.spec
        return (
            f"{self.spec} (port {self.port}, the Modbus/TCP default; tcp://HOST:PORT for "
            "another)"
        )


def parity_code(text: str) -> str:
    """``none|even|odd`` or ``N|E|O``, in any case, as "N", "E" or "O"."""
    spelling = text.strip().lower()
    code = PARITY_NAMES.get(spelling) or spelling.upper()
    if code not in PARITY_NAMES.values():
        raise UserError(f"parity '{text}': expected one of {', '.join(PARITY_SPELLINGS)}")
    return code


def check_serial_setting(baud: int, parity: str, stopbits: int) -> None:
    """Refuse a serial setting the gateway cannot be set to (manual 5.6: codes 10-83)."""
    if serial_setting_code(baud, parity, stopbits) is not None:
        return
    if baud not in BAUD_RATES:
        raise UserError(
            f"{baud} baud: the gateway runs at {', '.join(map(str, BAUD_RATES))} baud"
        )
    framings = ", ".join(f"{p}{s}" for p, s in FRAMINGS)
    raise UserError(
        f"parity {parity} with {stopbits} stop bits: the gateway offers parity and stop "
        f"bits {framings} (two stop bits only without parity)"
    )


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


def listen_address(text: str, option: str, example: str) -> tuple[str, int]:
    """``HOST:PORT`` where a server of ours listens (``--opcua``, ``--http``); a host left
    out is loopback, an IPv6 address may be in brackets."""
    host, sep, port = text.rpartition(":")
    number = port_number(port)
    if not sep or number is None:
        shown = text if len(text) <= 40 else f"{text[:37]}..."
        raise UserError(f"{option} '{shown}': expected HOST:PORT, e.g. {example}",
                        ExitCode.USAGE)
    return host.strip("[]") or "127.0.0.1", number


def is_loopback(host: str) -> bool:
    """Whether a server bound to ``host`` is reached from this machine only."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def parse_target(
    spec: str, *, baud: int = 9600, parity: str = "N", stopbits: int = 1
) -> ModbusTarget:
    """``--modbus`` as the user wrote it; a URL with another scheme is refused, not tried.
    A serial device's settings must be ones the gateway can be set to."""
    if "://" not in spec:
        code = parity_code(parity)
        check_serial_setting(baud, code, stopbits)
        return ModbusTarget(spec, device=spec, baud=baud, parity=code, stopbits=stopbits)
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
        rtu=match["scheme"] == "rtu+tcp", port_given=match["port"] is not None,
    )
