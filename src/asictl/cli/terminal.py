"""Whether diagnostics on stderr get colours.

Only on a terminal, and never when ``NO_COLOR`` is set (https://no-color.org): a log
file, a pipe or CI keeps plain text.
"""

from __future__ import annotations

import os
import sys


def stderr_colour() -> bool:
    if os.environ.get("NO_COLOR"):
        return False
    isatty = getattr(sys.stderr, "isatty", None)
    return bool(isatty is not None and isatty())
