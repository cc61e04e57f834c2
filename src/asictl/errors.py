"""Exit codes and the split between user errors and bugs.

Every failure the user can cause (a bad file, a bad option, a failed check) is a
``UserError`` carrying its exit code; the CLI prints its message without a traceback.
Anything else escaping to the CLI is a bug in asictl and is labelled as one.
"""

from __future__ import annotations

from enum import IntEnum


class ExitCode(IntEnum):
    """The exit codes of every asictl command, in one table."""

    OK = 0
    #: The command ran and found problems: errors in a checked file, a failed expectation.
    FAILED = 1
    #: The command could not run: bad usage, unreadable or malformed input.
    USAGE = 2
    #: An internal error: a bug in asictl.
    BUG = 3


class UserError(Exception):
    """A failure caused by input or environment, reported as a plain message."""

    exit_code: ExitCode = ExitCode.USAGE

    def __init__(self, message: str, exit_code: ExitCode | None = None) -> None:
        super().__init__(message)
        if exit_code is not None:
            self.exit_code = exit_code
