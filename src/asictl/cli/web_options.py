"""``--http HOST:PORT`` and its options, for ``serve`` and ``gateway serve`` alike: the
board's web page and REST API (asictl.web, the ``web`` extra; docs/web.md)."""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import TYPE_CHECKING, TypeVar

import click

from asictl.cli.options import Duration, apply_options
from asictl.errors import ExitCode, UserError, missing_extra
from asictl.host.transports.target import is_loopback, listen_address

if TYPE_CHECKING:
    from asictl.host.live.server import Attachment

F = TypeVar("F", bound=Callable[..., object])

#: Where the token may come from instead of a file (not the command line, which others see).
TOKEN_ENV = "ASICTL_HTTP_TOKEN"


def web_options(command: F) -> F:
    options = [
        click.option(
            "--http", "http", metavar="HOST:PORT",
            help="Also serve the board's web page and REST API here, e.g. 127.0.0.1:8080 "
            "(the 'web' extra; docs/web.md). Anywhere but loopback, put TLS in front.",
        ),
        click.option("--http-writable", is_flag=True,
                     help="Let the page and API clients with the token force, write, start, "
                     "stop, switch the mode, store, address slaves [default: read-only]."),
        click.option("--http-download", is_flag=True,
                     help="Also let them download programs (POST /api/download); needs "
                     "--http-writable [default: off]."),
        click.option("--http-token-file", type=click.Path(dir_okay=False), metavar="FILE",
                     help=f"The token writes need (else ${TOKEN_ENV}); at least 16 "
                     "characters."),
        click.option("--http-interval", type=Duration(least_ms=5, limit_ms=10_000),
                     default="50ms", show_default=True, metavar="TIME",
                     help="How often the board is read while a page listens."),
    ]
    return apply_options(command, options)


def _token(token_file: str | None) -> str | None:
    if token_file is None:
        return os.environ.get(TOKEN_ENV) or None
    try:
        with open(token_file, encoding="utf-8") as stream:
            token = stream.read().strip()
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"--http-token-file {token_file}: cannot read it: {exc}",
                        ExitCode.USAGE) from None
    if not token:
        raise UserError(f"--http-token-file {token_file}: the file is empty", ExitCode.USAGE)
    return token


def web_attachment(
    http: str | None, writable: bool, downloads: bool, token_file: str | None,
    interval: float, name: str, notify: Callable[[str], None],
) -> Attachment | None:
    """The web server the options ask for (None without --http); what is wrong with them
    is said before the board is served."""
    if http is None:
        given = [flag for flag, on in (("--http-writable", writable),
                                       ("--http-download", downloads),
                                       ("--http-token-file", token_file)) if on]
        if given:
            raise UserError(f"{', '.join(given)} without --http HOST:PORT", ExitCode.USAGE)
        return None
    host, port = listen_address(http, "--http", "127.0.0.1:8080")
    try:
        from asictl.web.access import check_token
        from asictl.web.server import WebOptions
        from asictl.web.server import web_attachment as attachment
    except ImportError as exc:
        raise missing_extra("--http", "web", str(exc)) from None
    if downloads and not writable:
        raise UserError("--http-download needs --http-writable (and its token)",
                        ExitCode.USAGE)
    token = _token(token_file)
    check_token(token, writable=writable)
    options = WebOptions(host, port, writable, token, interval, downloads)
    if not is_loopback(host):
        notify(f"warning: --http {host}:{port} serves other machines without TLS: anyone "
               "who reaches it sees the board" + (" and may try the token" if writable else "")
               + "; put a TLS reverse proxy in front (docs/web.md)")

    def started(url: str) -> None:
        access = "writable with the token" if writable else "read-only"
        access += ", takes programs" if downloads else ""
        notify(f"web page for board {name} at {url} ({access})")

    return attachment(options, name, started)
