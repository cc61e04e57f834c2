"""``asictl probe``: what a master tells without being changed, as a fixture
(host/probe.py, docs/verify.md "Bring-up on a real board")."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Unpack

import click

from asictl.cli.board_options import BoardOptions, board_options, master_wait, open_master
from asictl.files import write_together
from asictl.host.probe import probe, summary
from asictl.host.raw_image import to_hex


@click.command("probe")
@board_options
@click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False), metavar="FILE.json",
    help="The fixture to write; the EEPROM goes beside it as FILE.hex.",
)
def probe_command(output: str, **board: Unpack[BoardOptions]) -> None:
    """Read everything the master tells without changing it, into a fixture, and say
    which of asictl's assumptions it supports, contradicts or cannot tell.

    Only read-only requests are made (safe on a production master): the identification
    strings (0B0h-0FFh), software letters, flags, ec- and hi-flags, slave lists,
    configuration and parameter images and the whole DPRAM; the raw cycle-time bytes
    (300h-303h) read five times over two seconds; the answers of the read-only commands
    (51, 53 from FF00h, 56; through a gateway 65, 17 and register 1009); the whole EEPROM.
    FILE.json keeps them (the cycle times under cycle_time_bytes_300h_303h), FILE.hex the
    EEPROM up to its last non-blank line. The assumptions: the cycle-time unit (10 µs or
    10 ms), the entry table at FF00h, asictl's image format, the flag bits 5-7.

    On a real board: asictl probe --port 300h --io devport -o board-300h.json

    Exit status: 0 written, 1 the master did not answer, 2 bad usage.

    \b
    Examples:
      asictl download demos/blink.asi --start
      asictl probe -o board.json
    """
    path = Path(output)
    hex_path = path.with_suffix(".hex")
    with open_master(**board) as master:
        found = probe(master, master_wait(master), hex_path.name)
    write_together([
        (path, json.dumps(found.fixture, indent=2) + "\n"),
        (hex_path, to_hex(found.eeprom)),
    ])
    click.echo("\n".join(summary(found.fixture)))
    click.echo(f"{master.name}: wrote {path} and {hex_path}", err=True)
