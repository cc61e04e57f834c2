"""The gateway's own EEPROM: the Modbus address and serial setting its keys stored (gateway
manual 5.6, "nichtflüchtig im EEPROM abgelegt", line 384), kept beside the board's state.

``gateway serve`` starts with what is stored here unless its options say otherwise, as a
real gateway comes up with the settings it was given on its keys.
"""

from __future__ import annotations

import json
from pathlib import Path

from asictl.errors import UserError
from asictl.files import write_atomic
from asictl.host.transports.ports import port_name
from asictl.platform.gateway import UNITS, Interface, serial_setting_code


def interface_file(directory: Path, base: int) -> Path:
    return directory / f"gateway-{port_name(base).lower()}.json"


def load_interface(path: Path) -> Interface | None:
    """What the keys stored, None if nothing was; a damaged file is an error (exit 2)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise UserError(f"{path}: cannot read the gateway's stored settings: {exc}") from None
    try:
        interface = Interface(
            int(data["unit"]), int(data["baud"]), str(data["parity"]), int(data["stopbits"])
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise UserError(f"{path}: not the gateway's stored settings ({exc})") from None
    if interface.unit not in UNITS or serial_setting_code(
        interface.baud, interface.parity, interface.stopbits
    ) is None:
        raise UserError(f"{path}: settings the gateway cannot have: {data}")
    return interface


def save_interface(path: Path, interface: Interface) -> None:
    write_atomic(path, json.dumps({
        "unit": interface.unit, "baud": interface.baud, "parity": interface.parity,
        "stopbits": interface.stopbits,
    }, indent=1) + "\n")
