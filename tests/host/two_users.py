"""A second local user for the tests that need one: run as root (as CI does), act as
``nobody`` in a subprocess. /root is not readable by nobody, so what runs as nobody is a
system binary, or the system's /usr/bin/python3 with the standard library only, in a
folder under /tmp that every user can walk into (conftest's ``open_folder``)."""

from __future__ import annotations

import os
import subprocess

import pytest

NOBODY = 65534
SYSTEM_PYTHON = "/usr/bin/python3"
as_root = pytest.mark.skipif(os.geteuid() != 0, reason="a second user needs root to act as")


def _drop() -> None:
    os.setgid(NOBODY)
    os.setuid(NOBODY)


def as_nobody(*command: str, **options: object) -> subprocess.CompletedProcess[str]:
    """Run ``command`` as nobody to its end."""
    return subprocess.run(list(command), capture_output=True, text=True, preexec_fn=_drop,
                          cwd="/", **options)  # type: ignore[call-overload]


def start_as_nobody(*command: str) -> subprocess.Popen[str]:
    """Start ``command`` as nobody, its output piped."""
    return subprocess.Popen(list(command), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=_drop, cwd="/")
