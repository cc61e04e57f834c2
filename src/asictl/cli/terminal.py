"""What stderr shows on a terminal: colours for diagnostics, progress bars for transfers.

Colours only on a terminal, and never when ``NO_COLOR`` is set (https://no-color.org): a
log file, a pipe or CI keeps plain text; a progress bar is then only its label.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import click


def stderr_colour() -> bool:
    if os.environ.get("NO_COLOR"):
        return False
    isatty = getattr(sys.stderr, "isatty", None)
    return bool(isatty is not None and isatty())


@contextmanager
def progress(label: str, blocks: int) -> Iterator[Callable[[int], None]]:
    """A progress bar on stderr (only its label when stderr is not a terminal)."""
    with click.progressbar(
        length=blocks, label=label, file=sys.stderr, show_eta=False,
    ) as bar:
        yield bar.update
