"""Allow ``python -m asictl``."""

from asictl.cli import run

run()
