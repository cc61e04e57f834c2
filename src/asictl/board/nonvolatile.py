"""What survives power-off on a PC2 board, and its JSON form.

The real board keeps its EEPROM (the control program), the non-volatile AS-i Control
flags (manual 10.2.6), the operating mode and the master's settings (LPS, PCD, PP, LOS,
the Config_ok delay) across a power cycle; the emulation also keeps the installation:
the slaves on the cable, and its force list (board/forcing.py). The persistent emulated
boards of ``host.emulated.boards`` are this state saved between commands, so a malformed file is
refused naming the bad field, never half-loaded.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from asictl.board.asi import AsiBus, BusError
from asictl.board.execution import addresses
from asictl.board.forcing import Forces
from asictl.platform.master import CONTROL_FLAGS_NONVOLATILE, EEPROM_SIZE, NO_PROFILE, SLAVES
from asictl.platform.pc2 import IMAGE_SIZE, nibbles, pack_nibbles

FORMAT = "asictl-pc2-nonvolatile"
VERSION = 1


class NonvolatileError(ValueError):
    """Saved board state that cannot be powered up from."""


@dataclass
class Nonvolatile:
    """A board's non-volatile state; the defaults are a new board's."""

    #: all 16 KB (FFh where nothing was written)
    eeprom: bytes = b"\xff" * EEPROM_SIZE
    #: the AS-i Control flags that are stored (``CONTROL_FLAGS_NONVOLATILE``)
    control_flags: int = 0
    #: a new board starts in configuration mode
    configuration_mode: bool = True
    #: slave lists as bit masks, slave n = bit n
    lps: int = 0
    los: int = 0
    #: one byte per slave (ID code << 4 | I/O code)
    pcd: bytes = bytes([NO_PROFILE]) * SLAVES
    #: one value per slave, 0..15
    pp: bytes = bytes([0xF]) * SLAVES
    #: Config_ok 0->1 delay, 10 ms units
    config_ok_delay: int = 2
    bus: AsiBus = field(default_factory=AsiBus)
    #: the force list (board/forcing.py): the emulation's own, kept until released
    forced: Forces = field(default_factory=Forces)

    def to_json(self) -> dict[str, Any]:
        """JSON-able: the EEPROM as hex without its trailing FFh, lists as addresses."""
        return {
            "format": FORMAT,
            "version": VERSION,
            "eeprom": self.eeprom.rstrip(b"\xff").hex(),
            "control_flags": self.control_flags,
            "configuration_mode": self.configuration_mode,
            "lps": list(addresses(self.lps)),
            "pcd": self.pcd.hex(),
            "pp": pack_nibbles(self.pp).hex(),
            "los": list(addresses(self.los)),
            "config_ok_delay": self.config_ok_delay,
            "bus": self.bus.to_dict(),
            **({"forced": self.forced.to_json()} if self.forced else {}),
        }

    @classmethod
    def from_json(cls, data: object) -> Nonvolatile:
        """The state ``to_json`` wrote; ``NonvolatileError`` naming the first bad field."""
        if not isinstance(data, dict):
            raise NonvolatileError(f"board state must be an object, not {type(data).__name__}")
        if data.get("format") != FORMAT:
            raise NonvolatileError(
                f"not a saved PC2 board state (format {data.get('format')!r}, "
                f"expected {FORMAT!r})"
            )
        if data.get("version") != VERSION:
            raise NonvolatileError(
                f"saved board state version {data.get('version')!r}; "
                f"this asictl reads version {VERSION}"
            )
        eeprom = _hex(data, "eeprom", max_size=EEPROM_SIZE)
        control_flags = _byte(data, "control_flags") & CONTROL_FLAGS_NONVOLATILE
        mode = data.get("configuration_mode")
        if not isinstance(mode, bool):
            raise NonvolatileError(f"'configuration_mode' must be true or false, not {mode!r}")
        state = cls(
            eeprom=eeprom + b"\xff" * (EEPROM_SIZE - len(eeprom)),
            control_flags=control_flags,
            configuration_mode=mode,
            lps=_slave_list(data, "lps", first=1),
            los=_slave_list(data, "los", first=0),
            pcd=_hex(data, "pcd", size=SLAVES),
            pp=nibbles(_hex(data, "pp", size=IMAGE_SIZE)),
            config_ok_delay=_byte(data, "config_ok_delay"),
        )
        try:
            state.bus = AsiBus.from_dict(data.get("bus", {"slaves": []}))
        except BusError as exc:
            raise NonvolatileError(f"saved board state: bus: {exc}") from None
        try:
            state.forced = Forces.from_json(data.get("forced", {}))
        except ValueError as exc:  # ForceError among them
            raise NonvolatileError(f"saved board state: {exc}") from None
        return state


def _byte(data: dict[str, Any], key: str) -> int:
    value = data.get(key)
    if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= 0xFF:
        raise NonvolatileError(f"saved board state: '{key}' must be a byte 0..255, not {value!r}")
    return value


def _hex(data: dict[str, Any], key: str, *, size: int = -1, max_size: int = -1) -> bytes:
    text = data.get(key)
    try:
        raw = bytes.fromhex(text) if isinstance(text, str) else None
    except ValueError:
        raw = None
    if raw is None or (size >= 0 and len(raw) != size) or (0 <= max_size < len(raw)):
        wanted = f"{size} bytes" if size >= 0 else f"at most {max_size} bytes"
        raise NonvolatileError(f"saved board state: '{key}' must be hex text of {wanted}")
    return raw


def _slave_list(data: dict[str, Any], key: str, *, first: int) -> int:
    value = data.get(key)
    if not isinstance(value, list) or not all(
        isinstance(a, int) and not isinstance(a, bool) and first <= a < SLAVES for a in value
    ):
        raise NonvolatileError(
            f"saved board state: '{key}' must be a list of slave addresses {first}..31"
        )
    return sum(1 << a for a in set(value))
