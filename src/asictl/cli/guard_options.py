"""The overwrite guard's options (host/overwrite_guard.py), one wording for every command
that changes a master."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

import click

_Callback = TypeVar("_Callback", bound=Callable[..., object])


def real_master_option(command: _Callback) -> _Callback:
    return click.option(
        "--real-master", is_flag=True,
        help="Change a master that is not asictl's emulation (a real board or gateway: one "
        "whose name string or Modbus function 17 does not say 'asictl emulation'). Without "
        "it the command says what runs there and stops (exit 1): back it up first with "
        "'asictl upload -o backup.hex'.",
    )(command)


def unconfirmed_format_option(command: _Callback) -> _Callback:
    return click.option(
        "--unconfirmed-format", is_flag=True,
        help="With --real-master, for an image in asictl's own format: acknowledge that no "
        "real firmware is known to run it (docs/verify.md); --real-master alone is not "
        "enough for such an image.",
    )(command)
