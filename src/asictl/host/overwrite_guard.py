"""Never overwrite a real master by accident (docs/host.md "Real masters: the overwrite
guard").

A plant's master may hold the only copy of a program loaded years ago with the vendor's
tools, and an image in asictl's format is not known to run on real firmware
(docs/verify.md). So a command that changes a master first asks what it is talking to,
and where that is not asictl's emulation it says what it is about to replace and stops
unless the user gave the override (``--real-master``; for an image in asictl's format
also ``--unconfirmed-format``).

Emulation is recognised only by what asictl's emulation says about itself
(``platform.pc2.EMULATION_MARK``): a PC2 board's version string in its name field
(DPRAM 0B0h-0DFh), a gateway's answer to Modbus function 17. Never by a loopback
address, a state directory or the entry table at FF00h: a look-alike that does not say
it is treated as real.
"""

from __future__ import annotations

from dataclasses import dataclass

from asictl.errors import ExitCode, UserError
from asictl.host.master import Master
from asictl.host.status import read_program
from asictl.platform.pc2 import EMULATION_MARK, MASTER_NAME, MASTER_NAME_SIZE

REAL_MASTER = "--real-master"
UNCONFIRMED_FORMAT = "--unconfirmed-format"


@dataclass(frozen=True)
class Identification:
    """What a master says it is, and whether that is asictl's emulation."""

    text: str
    emulated: bool


def identify(master: Master) -> Identification:
    """The master's own words: a PC2 board's name and version string, a gateway's
    function 17 answer (a real VAG-MOD-KF-R4 has no function 17)."""
    if master.driver is not None:
        raw = master.driver.read(MASTER_NAME, MASTER_NAME_SIZE)
        text = " ".join(part.decode("ascii", "replace").strip()
                        for part in (raw[:32].split(b"\0")[0], raw[32:].split(b"\0")[0]))
        return Identification(text.strip(), EMULATION_MARK in text)
    from asictl.host.transports.modbus import ModbusTransport  # pymodbus: only for a gateway

    transport = master.transport
    if isinstance(transport, ModbusTransport):
        answer = transport.server_id()
        if answer is None:
            return Identification("a gateway without function 17 (Report Slave ID)", False)
        text = answer.decode("ascii", "replace").strip()
        return Identification(text, EMULATION_MARK in text)
    return Identification("a master that does not identify itself", False)


def what_it_holds(master: Master) -> str:
    """The program in the master's EEPROM in one phrase: asictl's identity, or what the
    EEPROM starts with."""
    info = read_program(master.transport).info
    if info.valid and info.identity:
        return f"asictl program {info.identity}"
    return info.problem or "no program image"


def check_overwrite(
    master: Master, action: str, *, real_master: bool, unconfirmed_format: bool = False,
    asictl_image: bool = False,
) -> None:
    """Refuse ``action`` (a phrase: "download an image in asictl's format") on a master
    that is not asictl's emulation unless the overrides are given: ``--real-master``,
    and for ``asictl_image`` also ``--unconfirmed-format``. The refusal says what runs
    there and offers the backup first (exit 1)."""
    who = identify(master)
    if who.emulated:
        return
    missing = [flag for flag, given in ((REAL_MASTER, real_master),
                                        (UNCONFIRMED_FORMAT, unconfirmed_format or not
                                         asictl_image)) if not given]
    if not missing:
        return
    why = (f"; the image is in asictl's own format, which no real firmware is known to run "
           f"(docs/verify.md), so {UNCONFIRMED_FORMAT} acknowledges that too"
           if asictl_image else "")
    raise UserError(
        f"{master.name} is not asictl's emulation (it identifies as '{who.text}'): "
        f"refused to {action}, which would change what runs there now: "
        f"{what_it_holds(master)}. Back it up first: 'asictl upload -o backup.hex' with the "
        "same board options (or 'asictl fleet backup'); then give "
        + " and ".join(missing) + f" to go ahead{why}",
        ExitCode.FAILED,
    )
