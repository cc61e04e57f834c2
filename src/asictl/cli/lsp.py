"""``asictl lsp``: the IL language server, speaking LSP over stdin and stdout.

pygls is an optional dependency (the ``lsp`` extra), so it is imported only here, when
the command runs; every other command, and ``asictl --help``, works without it.
"""

from __future__ import annotations

import importlib.util

import click

from asictl.cli.options import lib_option
from asictl.errors import missing_extra


@click.command()
@lib_option
def lsp(lib: tuple[str, ...]) -> None:
    """Run the language server on stdin/stdout (editors start it; see docs/editors.md).

    Diagnostics as 'asictl check' gives them, hover, go to definition, find references,
    completion, document symbols, folding and formatting for .asi and .fb files.

    \b
    Example:
      asictl lsp
    """
    if importlib.util.find_spec("pygls") is None:
        raise missing_extra("the language server", "lsp", "no pygls")
    from asictl.lsp.server import serve

    serve(lib)
