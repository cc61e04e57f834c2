"""Options several commands share, spelled and explained once."""

from __future__ import annotations

import click

#: ``--lib DIR`` (repeatable): where the loader looks for function-block files besides the
#: program's folder; every command that builds a program takes it.
lib_option = click.option(
    "--lib", "lib", multiple=True, type=click.Path(file_okay=False),
    help="Also look for function-block files here (repeatable; also $ASICTL_LIB).",
)
