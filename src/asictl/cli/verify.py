"""``asictl verify``: does the master run this program? (TIA's online/offline comparison.)

The file is built exactly as ``download`` builds it (asictl.build, against the master's
own entry points), then compared with the image in the master's EEPROM and with the
projected configuration the master works with now (docs/commissioning.md).
"""

from __future__ import annotations

from typing import Unpack

import click

from asictl.cli.board_options import BoardOptions, board_options, open_master
from asictl.cli.options import lib_option
from asictl.errors import ExitCode
from asictl.host.raw_image import holds_raw_program
from asictl.host.status import read_program
from asictl.host.transfer import upload_head
from asictl.image.eeprom import differences


@click.command("verify")
@click.argument("file", metavar="FILE.asi|FILE.hex", type=click.Path(dir_okay=False))
@board_options
@lib_option
def verify(file: str, lib: tuple[str, ...], **board: Unpack[BoardOptions]) -> None:
    """Compare FILE with the program in the master: identical, different (code,
    configuration, options) or no program there. FILE is source, [RAW] records or .hex,
    built as 'asictl download' would build it. Where either side is a raw image (the .hex
    'asictl upload' writes of a program not in asictl's format, or such a program in the
    master) the whole EEPROM is compared byte for byte: identical, or how many bytes
    differ and the first addresses.

    Exit status: 0 identical, 1 different, no program in the master or errors in FILE,
    2 bad usage or an unreadable file.

    \b
    Examples:
      asictl download demos/blink.asi
      asictl verify demos/blink.asi
      asictl verify demos/counter.asi   # exit 1: different
    """
    from asictl.build import build_file
    from asictl.cli.raw_images import compare, raw_file_or_none

    ctx = click.get_current_context()
    raw = raw_file_or_none(file)
    if raw is not None:
        with open_master(**board) as master:
            ctx.exit(int(ExitCode.OK if compare(master, file, raw) else ExitCode.FAILED))
    with open_master(**board) as master:
        built = build_file(file, entry_points=master.transport.entry_points(), lib=lib)
        click.echo(built.render(), nl=False, err=True)
        if built.has_errors or built.image is None:
            ctx.exit(int(ExitCode.FAILED))
        mine = built.image
        stored = read_program(master.transport)
        theirs = stored.image
        if theirs is None and holds_raw_program(upload_head(master.transport)):
            same = compare(master, file, mine.to_bytes())  # a raw image on the master's side
            ctx.exit(int(ExitCode.OK if same else ExitCode.FAILED))
        status = master.status() if theirs is not None else None
    if theirs is None:
        click.echo(f"{master.name}: {stored.info.problem or 'no program'} in the master "
                   f"(nothing to compare {file} with)")
        ctx.exit(int(ExitCode.FAILED))
    found = differences(mine, theirs)
    if found:
        click.echo(
            f"{master.name}: different: {file} ({mine.identity_hex}) and the master's "
            f"program ({theirs.identity_hex}) differ in " + ", ".join(found)
        )
        ctx.exit(int(ExitCode.FAILED))
    click.echo(f"{master.name}: identical: the master holds {file} ({mine.identity_hex})")
    if bool(mine.source) != bool(theirs.source):
        click.echo(f"{master.name}: note: only " + ("the master's copy" if theirs.source
                   else f"{file} as built") + " carries the source text", err=True)
    assert status is not None
    now = {n: status.slaves[str(n)].pcd for n in status.lps if str(n) in status.slaves}
    wanted = {n: mine.configuration.pcd[n] for n in mine.configuration.projected()}
    if now != wanted:
        click.echo(
            f"{master.name}: note: the master's projected configuration (LPS/PCD) has been "
            "changed since the download; 'asictl setup FILE' writes the program's again",
            err=True,
        )
    if master.driver is not None and status.program_status != "loaded":
        click.echo(
            f"{master.name}: note: the program is in the EEPROM but not loaded "
            f"({status.program_status}); 'asictl reset' loads it",
            err=True,
        )
