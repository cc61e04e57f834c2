"""Allow ``python -m asictl``."""

from asictl.cli import main

main()
