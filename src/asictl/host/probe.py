"""``asictl probe``: everything a master tells without being changed, as one fixture
(docs/verify.md "Bring-up on a real board").

asictl's design rests on assumptions only a real board can settle: the unit of the cycle
times, the entry table read from FF00h, its own image format, the AS-i Control flag bits
5-7. A probe reads what bears on them with read-only requests alone (DPRAM reads,
commands 51, 53 and 56; through a gateway functions 3, 7, 17, 65 and 67), never a
command that writes or clears, so it is safe on a production master. The fixture (JSON,
the EEPROM as an Intel HEX file beside it) keeps the raw answers; ``verdicts`` says
which assumptions they support, contradict or cannot decide; ``replay_differences``
compares a fixture with a fresh probe of the emulated board, so a fixture recorded on a
real board becomes a regression test of the emulator.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

from asictl.board.services import ENTRY_POINTS
from asictl.host.cycle_units import readings
from asictl.host.master import Master
from asictl.host.overwrite_guard import identify
from asictl.host.raw_image import is_asictl_image, is_blank, read_eeprom, used
from asictl.host.transports.jobs import JobError
from asictl.platform.master import ControlFlag
from asictl.platform.pc2 import (
    COMM_MEMORY_SIZE,
    CONTROL_FLAGS,
    CYCLE_TIME_PREVIOUS,
    DPRAM_SIZE,
    ENTRY_TABLE_ADDRESS,
    ENTRY_TABLE_SIZE,
    PROGRAM_BUFFER,
    PROGRAM_BUFFER_SIZE,
    Command,
)

FORMAT = "asictl probe fixture 1"
#: How often, and how far apart, the cycle-time bytes are read.
SAMPLES = 5
SAMPLE_INTERVAL_MS = 500.0
#: The key the raw cycle-time bytes are kept under.
CYCLE_KEY = "cycle_time_bytes_300h_303h"

Wait = Callable[[float], None]


@dataclass(frozen=True)
class Probe:
    """A fixture: the JSON document and the EEPROM it names (used part, as a backup)."""

    fixture: dict[str, Any]
    eeprom: bytes


def probe(master: Master, wait_ms: Wait, hex_name: str) -> Probe:
    """Read everything ``master`` tells without a change; ``wait_ms`` lets master time
    pass between the cycle-time samples."""
    who = identify(master)
    status = master.status()
    eeprom = used(read_eeprom(master.transport))
    fixture: dict[str, Any] = {
        "format": FORMAT,
        "master": master.name,
        "reached_through": "pc2" if master.driver is not None else "modbus",
        "identification": {"says": who.text, "asictl_emulation": who.emulated},
        "status": status.to_json(),
        "commands": _commands(master),
        CYCLE_KEY: _cycle_samples(master, wait_ms),
        "eeprom": {
            "file": hex_name, "bytes": len(eeprom),
            "sha256": hashlib.sha256(eeprom).hexdigest(),
            "starts_with": eeprom[:16].hex(" "),
        },
    }
    if master.driver is not None:
        fixture["dpram"] = master.driver.read(0, DPRAM_SIZE).hex()
    fixture["assumptions"] = verdicts(fixture, eeprom)
    return Probe(fixture, eeprom)


def _commands(master: Master) -> dict[str, Any]:
    """The answers of the read-only commands, each as its raw bytes (or why there is
    none: a refusal is an answer too)."""
    answers: dict[str, Any] = {}

    def ask(name: str, read: Callable[[], bytes | str | int | None]) -> None:
        try:
            value = read()
        except JobError as exc:
            answers[name] = {"refused": str(exc)}
            return
        answers[name] = value.hex() if isinstance(value, bytes) else value

    transport = master.transport
    ask("entry_table_ff00h", lambda: transport.read_eeprom(ENTRY_TABLE_ADDRESS, ENTRY_TABLE_SIZE))
    driver = master.driver
    if driver is not None:
        def comm_memory() -> bytes:
            out = b""
            for start in range(0, COMM_MEMORY_SIZE, PROGRAM_BUFFER_SIZE):
                size = min(PROGRAM_BUFFER_SIZE, COMM_MEMORY_SIZE - start)
                driver.command(Command.READ_COMM_MEMORY, data=size, address=start)
                out += driver.read(PROGRAM_BUFFER, size)
            return out

        def flags() -> int:
            driver.command(Command.GET_STATUS)
            return driver.read_byte(CONTROL_FLAGS)

        ask("51_get_status_flags_304h", flags)
        ask("56_communication_memory", comm_memory)
        return answers
    from asictl.host.transports import gateway_pdus as pdus
    from asictl.host.transports.modbus import ModbusTransport

    if isinstance(transport, ModbusTransport):
        for part, name in ((pdus.INFO_VERSION_ID, "version_id"), (pdus.INFO_NAME, "name"),
                           (pdus.INFO_VERSION, "version"), (pdus.INFO_SOFTWARE, "software")):
            ask(f"65_{name}", partial(transport.master_info, part))
        ask("17_report_slave_id", transport.server_id)
        ask("1009_control_flags", transport.control_flags)
    return answers


def _cycle_samples(master: Master, wait_ms: Wait) -> list[dict[str, Any]] | None:
    """The raw cycle-time bytes, refreshed by command 51, ``SAMPLES`` times; None through
    a gateway, which does not report them."""
    driver = master.driver
    if driver is None:
        return None
    samples = []
    for n in range(SAMPLES):
        if n:
            wait_ms(SAMPLE_INTERVAL_MS)
        driver.command(Command.GET_STATUS)
        raw = driver.read(CYCLE_TIME_PREVIOUS, 4)
        previous, maximum = int.from_bytes(raw[:2], "little"), int.from_bytes(raw[2:], "little")
        samples.append({
            "after_ms": n * SAMPLE_INTERVAL_MS, "hex": raw.hex(" "),
            "previous": previous, "maximum": maximum,
            "previous_readings": readings(previous), "maximum_readings": readings(maximum),
        })
    return samples


# --------------------------------------------------------------------------- verdicts

SUPPORTS, CONTRADICTS, CANNOT_TELL = "supports", "contradicts", "cannot tell"
#: A raw cycle time above this is over 1 s read in 10 ms units: implausible for a running
#: control program. Nothing is too short for 10 µs units (a small program's cycle on the
#: emulated board is one unit), so the cycle times alone never contradict them.
TOO_LONG_IF_10MS = 100


def verdicts(fixture: dict[str, Any], eeprom: bytes) -> list[dict[str, str]]:
    """Which of asictl's assumptions the probe supports, contradicts or cannot tell."""
    return [
        _verdict("cycle-time unit: 10 µs (asictl) rather than 10 ms (a vendor driver header)",
                 *_cycle_unit(fixture)),
        _verdict("the firmware's entry table is read with command 53 from FF00h",
                 *_entry_table(fixture)),
        _verdict("the firmware runs a program image in asictl's format", *_format(fixture, eeprom)),
        _verdict("AS-i Control flags bit 5 is control_active, bits 6-7 are unused",
                 *_flag_bits(fixture)),
    ]


def _verdict(assumption: str, verdict: str, why: str) -> dict[str, str]:
    return {"assumption": assumption, "verdict": verdict, "why": why}


def _cycle_unit(fixture: dict[str, Any]) -> tuple[str, str]:
    samples = fixture[CYCLE_KEY]
    if samples is None:
        return CANNOT_TELL, "a gateway does not report the cycle times"
    running = fixture["status"]["control_state"] == "running"
    values = [s["previous"] for s in samples]
    top = max(values)
    both = (f"raw {min(values)}..{top}: {top * 10 / 1000:g} ms if 10 µs, "
            f"{top * 10:g} ms if 10 ms")
    if not running or not top:
        return CANNOT_TELL, f"the control program is not running ({both})"
    if top > TOO_LONG_IF_10MS:
        return SUPPORTS, f"{both}; cycles over 1 s would be implausible"
    return CANNOT_TELL, (f"{both}; both readings are plausible: probe while a longer "
                         "program runs (docs/verify.md)")


def _entry_table(fixture: dict[str, Any]) -> tuple[str, str]:
    answer = fixture["commands"]["entry_table_ff00h"]
    if isinstance(answer, dict):
        return CONTRADICTS, f"53 from FF00h was refused ({answer['refused']})"
    table = bytes.fromhex(answer)
    if is_blank(table) or not table.strip(b"\0"):
        return CONTRADICTS, f"FF00h holds no table ({table[:4].hex(' ')} ...)"
    ours = b"".join(a.to_bytes(2, "little") for a in ENTRY_POINTS.values())
    if table == ours:
        return SUPPORTS, "the table asictl's emulation has"
    return SUPPORTS, ("a table other than the emulation's: compile for this master "
                      "against its own table (asictl does, on download)")


def _format(fixture: dict[str, Any], eeprom: bytes) -> tuple[str, str]:
    if is_blank(eeprom):
        return CANNOT_TELL, "the EEPROM is blank"
    if not is_asictl_image(eeprom):
        return CANNOT_TELL, (f"the EEPROM holds a program in another format (it starts with "
                             f"{eeprom[:4].hex(' ')}); only a download of asictl's image to a "
                             "test board tells")
    if fixture["status"]["control_state"] == "running":
        return SUPPORTS, "an image in asictl's format is in the EEPROM and the program runs"
    return CANNOT_TELL, "an image in asictl's format is in the EEPROM but does not run now"


def _flag_bits(fixture: dict[str, Any]) -> tuple[str, str]:
    flags = int(fixture["status"]["control_flags"])
    active = bool(flags & ControlFlag.CONTROL_ACTIVE)
    running = fixture["status"]["control_state"] == "running"
    shown = f"flags {flags:02X}h, control program {fixture['status']['control_state']}"
    if flags & 0xC0:
        return CONTRADICTS, f"{shown}: bits 6-7 are set"
    if active != running:
        return CONTRADICTS, f"{shown}: bit 5 does not follow the control program"
    if running:
        return SUPPORTS, f"{shown}: bit 5 set while the program runs"
    return CANNOT_TELL, f"{shown}: start a program to see bit 5 follow it"


# --------------------------------------------------------------------------- replay

def stable(fixture: dict[str, Any]) -> dict[str, Any]:
    """What a board reproduces whatever it runs and whenever it is probed: the name
    (without the version string, where the emulation says what it is), the version ID,
    the capability letters, the entry table, the EEPROM."""
    status = fixture["status"]
    if fixture.get("dpram") is not None:
        name = bytes.fromhex(fixture["dpram"])[0xB0:0xD0].split(b"\0")[0].decode("ascii", "replace")
    else:
        name = fixture["commands"].get("65_name")
    return {
        "master name": name,
        "version ID": status["version_id"],
        "capability letters (installed software 1-7)": status["installed_software"][1:8],
        "entry table (53 from FF00h)": fixture["commands"]["entry_table_ff00h"],
        "EEPROM (SHA-256)": fixture["eeprom"]["sha256"],
    }


def replay_differences(recorded: dict[str, Any], fresh: dict[str, Any]) -> list[str]:
    """Where a fresh probe of the emulated board, given the fixture's EEPROM, differs
    from a recorded fixture in what ``stable`` keeps: each as a line. A fixture from a
    real board names here what the emulator does differently."""
    mine, theirs = stable(recorded), stable(fresh)
    return [f"{name}: the fixture has {mine[name]!r}, the emulator gives {theirs[name]!r}"
            for name in mine if mine[name] != theirs[name]]


def summary(fixture: dict[str, Any]) -> list[str]:
    """The readable summary ``asictl probe`` prints."""
    who = fixture["identification"]
    lines = [f"{fixture['master']}: {who['says']}"
             + (" (asictl's emulation)" if who["asictl_emulation"] else "")]
    samples = fixture[CYCLE_KEY]
    if samples is not None:
        lines.append("cycle times 300h-303h: " + ", ".join(s["hex"] for s in samples)
                     + " (raw, little-endian previous then maximum)")
    lines.append(f"EEPROM: {fixture['eeprom']['bytes']} bytes used, starts with "
                 f"{fixture['eeprom']['starts_with'][:23]}")
    width = max(len(v["verdict"]) for v in fixture["assumptions"])
    lines += [f"{v['verdict'].ljust(width)}  {v['assumption']}: {v['why']}"
              for v in fixture["assumptions"]]
    return lines
