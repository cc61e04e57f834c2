"""Wiring: the adapter on the process's standard streams, with its two ways to start."""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable
from typing import BinaryIO

from asictl.dap.adapter import Adapter
from asictl.dap.simulated import launch
from asictl.dap.targets import Target
from asictl.lsp.framing import JSON


def run(requests: BinaryIO, replies: BinaryIO, lib: tuple[str, ...] = ()) -> None:
    """Serve one editor; standard output carries only the protocol (a stray print goes
    to standard error)."""

    def launch_with_lib(args: dict[str, JSON], out: Callable[[str], None]) -> Target:
        extra = args.get("lib") or []
        return launch({**args, "lib": [*lib, *(extra if isinstance(extra, list) else [extra])]},
                      out)

    def attach(args: dict[str, JSON], out: Callable[[str], None]) -> Target:
        from asictl.dap.attached import attach

        return attach(args, out)

    adapter = Adapter(requests, replies, {"launch": launch_with_lib, "attach": attach})
    with contextlib.redirect_stdout(sys.stderr):
        adapter.serve()
