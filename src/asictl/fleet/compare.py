"""``fleet verify`` and ``fleet status`` on one master: is it what the archive holds, and
what is it doing.

Verifying is ``asictl verify`` with the archived image as the file: the image is built
as ``download`` would build it (asictl.build, against the master's own entry points),
then compared with the one in the master's EEPROM in the words of the program's sections
(image.eeprom.differences). An archived raw image (a program not in asictl's format) is
compared with the whole EEPROM byte for byte.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from asictl.build import build_file, is_hex, program_of_image
from asictl.diagnostics import DiagnosticError
from asictl.fleet.archive import archived_image
from asictl.fleet.inventory import FleetMaster
from asictl.host.master import Master
from asictl.host.raw_image import (
    Comparison,
    from_hex,
    holds_raw_program,
    is_asictl_image,
    read_eeprom,
    used,
)
from asictl.host.raw_image import identity as raw_identity
from asictl.host.status import program_info, read_program
from asictl.host.transfer import upload_head
from asictl.il.networks import compare
from asictl.image.eeprom import ProgramImage, differences
from asictl.source import read_source


@dataclass(frozen=True)
class Verdict:
    """How the master's program compares with the archive's: ``identical``,
    ``different`` (with what differs), ``no program`` (in the master) or ``not archived``."""

    state: str
    archived: str | None = None
    running: str | None = None
    details: tuple[str, ...] = ()
    #: for ``different`` when both images carry their IL source: what changed, network by
    #: network (``asictl diff``'s lines), so the report says where and not only that
    networks: tuple[str, ...] = ()

    def describe(self) -> str:
        if self.state == "identical":
            return f"identical ({self.running})"
        if self.state == "different":
            where = f" ({'; '.join(self.networks)})" if self.networks else ""
            return (f"different: the master runs {self.running}, the archive holds "
                    f"{self.archived}; they differ in {', '.join(self.details)}{where}")
        if self.state == "no program":
            return f"no program in the master (the archive holds {self.archived})"
        return "not in the archive (back it up first)"


def verify_master(archive: Path, fleet_master: FleetMaster, master: Master) -> Verdict:
    """Compare the master's program with the image archived for it (the work of
    ``fleet verify``, with ``archive`` bound, for ``survey.each_master``)."""
    entry_points = master.transport.entry_points()  # the master answers, archived or not
    path = archived_image(archive, fleet_master.name)
    if path is None:
        return Verdict("not archived")
    source = read_source(path)
    if is_hex(source.text):
        try:
            raw = from_hex(source)
        except DiagnosticError as exc:
            return Verdict("different", "an unreadable image", None,
                           (f"the archive: {exc.diagnostics[0].message}",))
        if not is_asictl_image(raw):
            return _verify_raw(raw, master)
    built = build_file(str(path), entry_points=entry_points)
    mine = built.image
    if built.has_errors or mine is None:
        first = next((d.message for d in built.diagnostics if d.is_error), "no image")
        return Verdict("different", "an unreadable image", None, (f"the archive: {first}",))
    theirs = read_program(master.transport).image
    if theirs is None:
        return Verdict("no program", mine.identity_hex)
    found = differences(mine, theirs)
    if found:
        return Verdict("different", mine.identity_hex, theirs.identity_hex, tuple(found),
                       network_changes(mine, theirs))
    return Verdict("identical", mine.identity_hex, theirs.identity_hex)


def _verify_raw(archived: bytes, master: Master) -> Verdict:
    """A raw image (a program not in asictl's format) against the whole EEPROM, byte
    for byte."""
    eeprom = read_eeprom(master.transport)
    found = Comparison.of(archived, eeprom)
    mine, theirs = raw_identity(archived), raw_identity(used(eeprom))
    if found.identical:
        return Verdict("identical", mine, theirs)
    return Verdict("different", mine, theirs, (f"the EEPROM: {found.describe()}",))


@dataclass(frozen=True)
class Glance:
    """A master in one line: what its control program does, and which program it holds."""

    summary: str
    program: str | None


def glance(_: FleetMaster, master: Master) -> Glance:
    """``raw`` for a program not in asictl's format: its identity would take reading the
    whole EEPROM, too slow for a glance through a gateway."""
    info = program_info(master.transport)
    if info.valid:
        return Glance(master.summary(), info.identity)
    raw = holds_raw_program(upload_head(master.transport))
    return Glance(master.summary(), "raw" if raw else None)


def network_changes(archived: ProgramImage, running: ProgramImage) -> tuple[str, ...]:
    """The networks that differ, as ``asictl diff ARCHIVED RUNNING`` names them (first
    line each); none when either image has no IL source to compare."""
    old, new = program_of_image(archived), program_of_image(running)
    if old is None or new is None:
        return ()
    return tuple(" ".join(change.lines()[0].split()) for change in compare(old, new)
                 if change.kind not in ("same", "renamed"))

