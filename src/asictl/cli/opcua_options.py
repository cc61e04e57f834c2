"""``--opcua HOST:PORT`` and its options, for ``serve`` and ``gateway serve`` alike: the
board's OPC UA server (asictl.opcua, the ``opcua`` extra; docs/opcua.md)."""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import TYPE_CHECKING, TypeVar

import click

from asictl.cli.options import Duration, apply_options
from asictl.diagnostics import DiagnosticError, render_text
from asictl.errors import ExitCode, UserError, missing_extra
from asictl.host.transports.target import listen_address
from asictl.opcua.limits import (
    DEFAULT_LOGIN_TIMEOUT_S,
    DEFAULT_MAX_CONNECTIONS,
    DEFAULT_MAX_SESSIONS,
)

if TYPE_CHECKING:
    from asictl.host.live.server import Attachment

F = TypeVar("F", bound=Callable[..., object])

#: Where the password of --opcua-user comes from (not the command line, which others see).
PASSWORD_ENV = "ASICTL_OPCUA_PASSWORD"


def opcua_options(command: F) -> F:
    options = [
        click.option(
            "--opcua", "opcua", metavar="HOST:PORT",
            help="Also serve the board over OPC UA here, e.g. 127.0.0.1:4840 (the 'opcua' "
            "extra; docs/opcua.md). Anonymous clients only on a loopback address.",
        ),
        click.option("--opcua-writable", is_flag=True,
                     help="Let OPC UA clients write flags and the cable's inputs, and call "
                     "Start and Stop [default: read-only]."),
        click.option("--opcua-user", metavar="NAME",
                     help=f"Only this user may connect, with the password in ${PASSWORD_ENV} "
                     "(needed on an address other than loopback)."),
        click.option("--opcua-interval", type=Duration(least_ms=10, limit_ms=10_000),
                     default="100ms", show_default=True, metavar="TIME",
                     help="How often the values are read from the board (the rate "
                     "subscriptions see changes at)."),
        click.option("--opcua-max-connections", type=click.IntRange(1, 1000),
                     default=DEFAULT_MAX_CONNECTIONS, show_default=True,
                     help="OPC UA connections at once (one not yet logged in included); "
                     "further ones are closed at once."),
        click.option("--opcua-max-sessions", type=click.IntRange(1, 1000),
                     default=DEFAULT_MAX_SESSIONS, show_default=True,
                     help="OPC UA sessions at once; a further one is refused "
                     "(BadMaxConnectionsReached)."),
        click.option("--opcua-login-timeout", type=Duration(least_ms=100, limit_ms=600_000),
                     default=f"{DEFAULT_LOGIN_TIMEOUT_S:g}s", show_default=True,
                     metavar="TIME", help="Close an OPC UA connection that has not logged "
                     "in (activated a session) this long after connecting."),
        click.option("--opcua-symbols", type=click.Path(dir_okay=False, exists=True),
                     metavar="FILE.symbols.toml",
                     help="A symbol table whose names become variables (docs/debugging.md)."),
    ]
    return apply_options(command, options)


def opcua_attachment(
    opcua: str | None, writable: bool, user: str | None, interval: float,
    symbols: str | None, name: str, notify: Callable[[str], None], *,
    max_connections: int, max_sessions: int, login_timeout: float,
) -> Attachment | None:
    """The OPC UA server the options ask for (None without --opcua); what is wrong with
    them is said before the board is served. ``login_timeout`` in seconds."""
    if opcua is None:
        given = [flag for flag, on in (("--opcua-writable", writable), ("--opcua-user", user),
                                       ("--opcua-symbols", symbols)) if on]
        if given:
            raise UserError(f"{', '.join(given)} without --opcua HOST:PORT", ExitCode.USAGE)
        return None
    host, port = listen_address(opcua, "--opcua", "127.0.0.1:4840")
    try:
        from asictl.opcua.server import OpcUaOptions, check_access
        from asictl.opcua.server import opcua_attachment as attachment
    except ImportError as exc:
        raise missing_extra("--opcua", "opcua", str(exc)) from None
    table = None
    if symbols is not None:
        from asictl.observe.operands import parse_operand
        from asictl.observe.symbols import load_symbols

        try:
            table = load_symbols(symbols, lambda text: str(parse_operand(text)))
        except DiagnosticError as exc:
            from asictl.source import read_source

            text = read_source(symbols).text
            click.echo(render_text(exc.diagnostics, {symbols: text}), nl=False, err=True)
            click.get_current_context().exit(int(ExitCode.USAGE))
    password = os.environ.get(PASSWORD_ENV) if user is not None else None
    if user is not None and not password:
        raise UserError(f"--opcua-user {user}: set its password in ${PASSWORD_ENV}",
                        ExitCode.USAGE)
    options = OpcUaOptions(
        host, port, writable, user, password, interval, table, max_connections=max_connections,
        max_sessions=max_sessions, login_timeout=login_timeout,
    )
    check_access(options)

    def started(url: str) -> None:
        access = "writable" if writable else "read-only"
        login = f"user {user}" if user else "anonymous"
        notify(f"OPC UA server for board {name} at {url} ({access}, {login})")

    return attachment(options, name, notify, started)
