"""``upload``, ``download --raw`` and ``verify`` of raw images (host.raw_image): a
master's program that is not in asictl's format, byte for byte (docs/host.md "Raw
images").

The commands in cli.master and cli.verify hand over to these functions where a raw image
is involved; everything else they do stays theirs.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import click

from asictl.build import is_hex
from asictl.cli.terminal import progress
from asictl.diagnostics import DiagnosticError, render_text
from asictl.errors import ExitCode
from asictl.files import STDOUT, shown_name, write_output
from asictl.host.master import Master
from asictl.host.master_record import make_record, read_record, record_path, record_text
from asictl.host.program_files import write_files
from asictl.host.raw_image import (
    Comparison,
    download_raw,
    from_hex,
    is_asictl_image,
    read_eeprom,
    steps,
    to_hex,
    used,
)
from asictl.host.transfer import WRITABLE_FLAGS, reset
from asictl.host.transports.jobs import JobError
from asictl.platform.master import EEPROM_SIZE
from asictl.source import SourceText, read_source


@dataclass(frozen=True)
class RawUpload:
    """What a raw upload read: the used part of the EEPROM and the master's record."""

    image: bytes
    record: dict[str, object]

    def extent(self) -> str:
        size = len(self.image)
        if size == EEPROM_SIZE:
            return f"the whole {EEPROM_SIZE // 1024} KB EEPROM"
        if not size:
            return "nothing: the EEPROM is blank"
        return (f"0000h-{size - 1:04X}h ({size} bytes); the rest of the {EEPROM_SIZE // 1024} "
                "KB EEPROM is blank (FFh)")


def read_raw(master: Master, hex_name: str) -> RawUpload:
    """The master's EEPROM and what it reports (identification, configuration, flags)."""
    transport = master.transport
    with progress(f"upload {EEPROM_SIZE} bytes", steps(transport)) as bar:
        image = used(read_eeprom(transport, bar))
    return RawUpload(image, make_record(master.status(), image, hex_name))


def hex_output(output: str) -> Path:
    """Where a raw upload to ``-o OUTPUT`` writes its HEX file: OUTPUT if it is one,
    else beside it under the same stem."""
    path = Path(output)
    return path if path.suffix.lower() == ".hex" else path.with_suffix(".hex")


def write_raw(master: Master, upload: RawUpload, output: str, *, overwrite: bool) -> None:
    """Write the HEX file and its record (all or none), and say what they are."""
    text = to_hex(upload.image)
    said = (f"{master.name}: the master's program is not in asictl's format: uploaded the "
            f"EEPROM byte for byte, {upload.extent()}")
    if output == STDOUT:
        write_output(STDOUT, text)
        click.echo(f"{said}; the record of the master's settings is written only beside "
                   "a file (-o FILE.hex)", err=True)
        return
    hex_path = hex_output(output)
    files = [(hex_path, text.encode("ascii")),
             (record_path(hex_path), record_text(upload.record).encode("utf-8"))]
    written = write_files(files, overwrite=overwrite)
    click.echo(
        f"{said}; " + (f"wrote {', '.join(shown_name(str(p)) for p in written)}" if written
                       else "files already up to date")
        + f" ('asictl download {shown_name(str(hex_path))} --raw' writes it back)",
        err=True,
    )


def read_raw_file(file: str) -> bytes:
    """The raw image of an Intel HEX file; a malformed one is shown with its line (exit 2)."""
    source = read_source(file)
    if not is_hex(source.text):
        raise click.UsageError(f"{file}: --raw takes an Intel HEX file (from 'asictl upload')")
    return _parsed(source)


def raw_file_or_none(file: str) -> bytes | None:
    """The raw image in ``file`` if it is an Intel HEX file that does not hold an asictl
    image (``verify`` compares those byte for byte); None for anything else."""
    source = read_source(file)
    if not is_hex(source.text):
        return None
    image = _parsed(source)
    return None if is_asictl_image(image) else image


def _parsed(source: SourceText) -> bytes:
    try:
        return from_hex(source)
    except DiagnosticError as exc:
        click.echo(render_text(exc.diagnostics, {source.name: source.text}), nl=False, err=True)
        click.get_current_context().exit(int(ExitCode.USAGE))


def restore(master: Master, file: str, image: bytes, *, restore_setup: bool) -> None:
    """``download FILE.hex --raw``: the configuration and flags from the record if asked,
    the image block by block and read back, then the reset bit that loads it."""
    transport = master.transport
    setup = read_record(record_path(file)) if restore_setup else None
    if setup is not None:
        transport.write_configuration(setup[0])
        transport.write_control_flags(setup[1] & WRITABLE_FLAGS)
    with progress(f"download {EEPROM_SIZE} bytes", 2 * steps(transport)) as bar:
        download_raw(transport, image, bar)
    how = "identical when read back"
    try:
        reset(transport)
    except JobError:
        how += ("; the master did not load it (it found no program it runs: asictl's "
                "emulated board runs only asictl's format)")
    master.settle()
    click.echo(
        f"{master.name}: downloaded {file} byte for byte ({len(image)} bytes, "
        f"{'configuration and flags from the record, ' if setup else ''}{how}); "
        f"{master.summary()}",
        err=True,
    )


def compare(master: Master, file: str, mine: bytes) -> bool:
    """``verify``: the master's EEPROM against a raw image, said plainly; True if equal."""
    with progress(f"compare {EEPROM_SIZE} bytes", steps(master.transport)) as bar:
        theirs = read_eeprom(master.transport, bar)
    found = Comparison.of(mine, theirs)
    if found.identical:
        click.echo(f"{master.name}: identical: the EEPROM holds {file} byte for byte")
        return True
    click.echo(f"{master.name}: different: {file} and the master's EEPROM: {found.describe()}")
    return False
