"""The record beside a raw image: what the master reported when it was backed up.

A raw image is the EEPROM alone; the projected configuration (LPS, PCD, PP) and the
AS-i Control flags live in the master beside it, and a program loaded years ago with the
vendor's tools needs them as much as its bytes. The record keeps them, with the master's
identification, as JSON beside the HEX file (``backup.hex`` -> ``backup.json``), so a
restore can put them back when asked (``download --raw --restore-setup``) and a reader
sees what the backup came from.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from asictl.errors import UserError
from asictl.host.status import MasterStatus
from asictl.image.eeprom import Configuration
from asictl.platform.master import EEPROM_SIZE, SLAVES

FORMAT = "asictl raw image record 1"


def record_path(hex_path: str | Path) -> Path:
    return Path(hex_path).with_suffix(".json")


def make_record(status: MasterStatus, image: bytes, hex_name: str) -> dict[str, Any]:
    """The record of ``image`` as uploaded from the master ``status`` describes."""
    projected = [n for n in status.lps if str(n) in status.slaves]
    return {
        "format": FORMAT,
        "image": {
            "file": hex_name,
            "bytes": len(image),
            "eeprom_bytes": EEPROM_SIZE,
            "sha256": hashlib.sha256(image).hexdigest(),
            "note": "the EEPROM byte for byte, up to its last non-blank 16-byte line; "
            "the rest is blank (FFh); not a program image in asictl's format",
        },
        "master": {
            "port": status.port,
            "name": status.master_name,
            "version_id": status.version_id,
            "installed_software": status.installed_software,
            "ec_flags": status.ec_flags,
            "hi_flags": status.hi_flags,
        },
        "control_flags": status.control_flags,
        "configuration": {
            "lps": projected,
            "pcd": {str(n): status.slaves[str(n)].pcd for n in projected},
            "pp": {str(n): status.slaves[str(n)].pp for n in projected},
        },
    }


def record_text(record: dict[str, Any]) -> str:
    return json.dumps(record, indent=2) + "\n"


def read_record(path: Path) -> tuple[Configuration, int]:
    """The configuration and AS-i Control flags a record keeps; a missing or damaged
    record is a ``UserError`` naming it."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if data.get("format") != FORMAT:
            raise ValueError(f"its format is not '{FORMAT}'")
        setup = data["configuration"]
        lps, pcd, pp = bytearray(4), bytearray(Configuration().pcd), bytearray(
            Configuration().pp)
        for n in setup["lps"]:
            if not isinstance(n, int) or not 0 <= n < SLAVES:
                raise ValueError(f"slave {n!r} in lps")
            lps[n // 8] |= 1 << n % 8
            pcd[n] = int(setup["pcd"][str(n)]) & 0xFF
            shift = 4 * (n % 2)
            pp[n // 2] = pp[n // 2] & ~(0xF << shift) | (int(setup["pp"][str(n)]) & 0xF) << shift
        flags = int(data["control_flags"]) & 0xFF
    except OSError as exc:
        raise UserError(
            f"{path}: cannot read the record of the raw image: {exc.strerror or exc} "
            "(--restore-setup needs the record 'asictl upload' wrote beside the HEX file)"
        ) from None
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise UserError(f"{path}: not a raw image record: {exc}") from None
    return Configuration(bytes(lps), bytes(pcd), bytes(pp)), flags
