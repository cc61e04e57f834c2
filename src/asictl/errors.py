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
    #: A program with errors is this from every command that reads one (docs/commands.md
    #: "Exit status"): the file was read, and what is wrong is in it, not in the call.
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


#: The optional extras and what each installs, as pyproject.toml declares them (a test
#: holds the two equal), so that an install hint names exactly what the extra would add.
EXTRAS: dict[str, tuple[str, ...]] = {
    "plot": ("matplotlib>=3.7",),
    "modbus": ("pymodbus==3.16.*", "pyserial>=3.5"),
    "lsp": ("pygls>=2.0,<3",),
    "monitor": ("textual>=8,<9",),
    "opcua": ("asyncua>=2.1,<3",),
    "prove": ("z3-solver>=4.12",),
    "web": ("starlette>=0.40,<2", "uvicorn>=0.30"),
}


def missing_extra(what: str, extra: str, cause: str = "") -> UserError:
    """The error for a command whose optional extra is not installed. asictl is not on
    PyPI, so installing ``asictl[x]`` by name would fail: the hint names the packages
    themselves, and the extra for a checkout."""
    packages = " ".join(f"'{p}'" for p in EXTRAS[extra])
    because = f" ({cause})" if cause else ""
    return UserError(
        f"{what} needs the '{extra}' extra{because}: pip install {packages} "
        f"(or, in an asictl checkout, pip install '.[{extra}]')",
        ExitCode.USAGE,
    )
