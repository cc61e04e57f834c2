"""The serial-line options the Modbus client and ``gateway serve`` share.

Both ends of the line must agree, so both accept exactly the settings the gateway can be
set to (platform/gateway.py) and the same spellings: ``--parity`` takes ``none|even|odd``
as well as the manual's ``N|E|O``, in any case.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import click

from asictl.host.transports.target import PARITY_SPELLINGS, parity_code
from asictl.platform.gateway import BAUD_RATES, DEFAULT_BAUD, UNITS

F = TypeVar("F", bound=Callable[..., Any])


def _parity(ctx: click.Context, param: click.Parameter, value: str) -> str:
    return parity_code(value)


def serial_options(what: str) -> Callable[[F], F]:
    """``--baud``, ``--parity`` and ``--stopbits``; ``what`` says when they apply."""

    def decorate(command: F) -> F:
        for option in reversed([
            click.option(
                "--baud", type=click.Choice([str(b) for b in BAUD_RATES]),
                default=str(DEFAULT_BAUD), show_default=True, help=f"{what}: bits per second.",
            ),
            click.option(
                "--parity", type=click.Choice(PARITY_SPELLINGS, case_sensitive=False),
                callback=_parity, default="none", show_default=True,
                metavar="[" + "|".join(PARITY_SPELLINGS) + "]",
                help=f"{what}: parity bit (none, even, odd; also N, E, O).",
            ),
            click.option(
                "--stopbits", type=click.Choice(["1", "2"]), default="1", show_default=True,
                help=f"{what}: stop bits (2 only without parity, as on the gateway).",
            ),
        ]):
            command = option(command)
        return command

    return decorate


def unit_option(help_text: str) -> Callable[[F], F]:
    """``--unit``: the gateway's Modbus address, within what it can be set to."""
    return click.option(
        "--unit", type=click.IntRange(UNITS[0], UNITS[-1]), default=1, show_default=True,
        help=help_text,
    )

