"""A one-shot command against a served board talks to it through its socket: most of
its time would be spent importing what it does not use. So it loads neither the compiler
(lark, the IL reader, the checks), nor the emulated board and its 8051 emulator (the
server runs them), nor asyncio (only servers read asyncio streams), nor the conditions
of ``asictl watch``. Each command runs as its own process, as a user runs it, and says
at exit which modules it loaded (docs/performance.md, "One-shot commands on a live
board"). What is imported is tested here, never how long it takes.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from live_helpers import ROOT, cli, start_serve, stop

#: What a command that only reaches a served board must not load.
HEAVY = (
    "lark", "asictl.build", "asictl.il.parser", "asictl.il.checks", "asictl.codegen8051",
    "asictl.board.board", "asictl.mcs51.emulator", "asictl.runtime.runner",
    "asictl.host.live.server", "asictl.observe.condition", "asyncio", "ssl", "pymodbus",
)

#: ``asictl ARGS`` in this process, the modules loaded by its end written to a file.
_RUN = """\
import atexit, json, sys
out, sys.argv = sys.argv[1], ["asictl", *sys.argv[2:]]
atexit.register(lambda: open(out, "w").write(json.dumps(sorted(sys.modules))))
from asictl.cli import run
run()
"""


@pytest.fixture(scope="module")
def state(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    state = tmp_path_factory.mktemp("served") / "state"
    process = start_serve(state)
    try:
        assert cli(state, "bus", "plug", "4", "iiii,0").exit_code == 0
        yield state
    finally:
        assert stop(process) == 0


def loaded(state: Path, tmp_path: Path, *args: str) -> list[str]:
    """The modules ``asictl ARGS`` loaded against the board served in ``state``; it
    must succeed."""
    out = tmp_path / "modules.json"
    done = subprocess.run(
        [sys.executable, "-c", _RUN, str(out), *args, "--state-dir", str(state)],
        capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    modules: list[str] = json.loads(out.read_text())
    return modules


def heavy(modules: list[str]) -> list[str]:
    return [m for m in modules if m in HEAVY or m.startswith(tuple(f"{h}." for h in HEAVY))]


@pytest.mark.parametrize(
    "args",
    [
        ("status",),
        ("status", "--json"),
        ("bus", "inputs", "4", "0b0001"),
        ("bus", "inputs", "I 4.1=1"),
        ("force", "F 10.0=1"),
        ("force", "--list"),
        ("unforce", "F 10.0"),
        ("write", "F 11.0=1", "FY 12=0x55"),
        ("bus",),
    ],
    ids=" ".join,
)
def test_a_command_on_a_served_board_loads_neither_compiler_nor_board(
    state: Path, tmp_path: Path, args: tuple[str, ...],
):
    modules = loaded(state, tmp_path, *args)
    assert "asictl.host.live.client" in modules  # it did reach the served board
    assert heavy(modules) == []


def test_the_check_sees_what_a_command_loads(state: Path, tmp_path: Path):
    """The rule above would pass vacuously if nothing heavy were ever seen: a download
    compiles, with lark."""
    program = tmp_path / "p.asi"
    program.write_text("[PROGRAM]\n        A   F 1.0\n        =   F 2.0\n        BE\n[END]\n")
    modules = loaded(state, tmp_path, "download", str(program))
    assert {"lark", "asictl.build", "asictl.il.parser"} <= set(heavy(modules))
