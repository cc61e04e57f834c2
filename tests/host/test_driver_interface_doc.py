"""docs/host.md's decision on the P+F-compatible ``ASI_com`` messages: every message of
the PC2 manual's table 10.1 is listed once, with asictl commands that exist."""

from __future__ import annotations

import re
from pathlib import Path

import click

from asictl.cli import main

ROOT = Path(__file__).resolve().parents[2]
#: the message codes of the manual's table 10.1 (003, "Driver Commands in compatibility
#: with other masters of Pepperl+Fuchs")
MANUAL = {*range(0x61, 0x70), 0x70, 0x71, 0x72, 0x73, 0x74, 0x76, 0x77, 0x78, 0x7D, 0x81}


def _rows() -> list[tuple[set[int], list[str]]]:
    text = (ROOT / "docs" / "host.md").read_text()
    section = text.split("(`ASI_com`): not provided", 1)[1].split("\n### ", 1)[0]
    rows = []
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        codes = re.findall(r"\b([0-9A-F]{2})h\b", cells[1]) if len(cells) == 3 else []
        if codes:
            rows.append(({int(c, 16) for c in codes}, re.findall(r"`asictl ([^`]+)`", cells[2])))
    return rows


def test_every_message_of_the_manual_is_listed_once():
    codes = [c for found, _ in _rows() for c in found]
    assert sorted(codes) == sorted(MANUAL)


def test_every_command_named_exists():
    for _, commands in _rows():
        assert commands
        for command in commands:
            group: click.Command = main
            for word in command.split():
                if not isinstance(group, click.Group):  # the rest are its arguments
                    break
                found = group.get_command(click.Context(group), word)
                assert found is not None, f"no 'asictl {command}'"
                group = found
