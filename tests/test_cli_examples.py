"""The examples that end every command's help run as written, so none can drift.

Each command's example lines run one after the other in bash, in a fresh folder holding a
copy of demos/, with a fresh emulated board (``ASICTL_STATE_DIR``); each must exit 0, or
the status its comment names (``# exit 1``). The commands that need a served board run
while ``asictl gateway serve`` serves it. Servers themselves would not end: their example
lines are only parsed, as click parses them before running a command.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import click
import pytest
from served_gateway import serve_gateway

from asictl.cli import main

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))

import commands_doc  # noqa: E402 - tools/ is not a package

#: Commands that serve until stopped (or take over the terminal): parsed, not run.
SERVERS = {"asictl serve", "asictl gateway serve", "asictl monitor", "asictl lsp",
           "asictl dap"}
#: Commands whose examples talk to a served board: run while a gateway serves it.
NEED_A_SERVED_BOARD = {"asictl record", "asictl gateway", "asictl gateway panel",
                       "asictl gateway press"}
_EXIT = re.compile(r"#\s*exit (\d+)")
_ALL = {ctx.command_path: commands_doc.examples(command)
        for ctx, command in commands_doc.commands()}


def _run(lines: list[str], folder: Path, state: Path) -> None:
    env = {**os.environ, "ASICTL_STATE_DIR": str(state), "PYTHONPATH": os.pathsep.join(
        [str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    define = f'asictl() {{ {shlex.quote(sys.executable)} -m asictl "$@"; }}\n'
    for line in lines:
        expected = _EXIT.search(line)
        result = subprocess.run(
            ["bash", "-c", define + line], cwd=folder, env=env, capture_output=True,
            text=True, stdin=subprocess.DEVNULL, timeout=120,
        )
        assert result.returncode == (int(expected.group(1)) if expected else 0), (
            f"{line}: exit {result.returncode}\n{result.stdout}\n{result.stderr}"
        )


def _folder(tmp_path: Path) -> Path:
    folder = tmp_path / "work"
    shutil.copytree(ROOT / "demos", folder / "demos")
    return folder


_RUN = sorted(path for path in _ALL if path not in SERVERS)


@pytest.mark.parametrize("path", _RUN)
def test_the_examples_of_each_command_run(path: str, tmp_path: Path) -> None:
    folder, state = _folder(tmp_path), tmp_path / "state"
    if path in NEED_A_SERVED_BOARD:
        with serve_gateway(state):
            _run(_ALL[path], folder, state)
    else:
        _run(_ALL[path], folder, state)


def _parse(line: str) -> None:
    """Click's parse of ``asictl [GROUP...] COMMAND ARGS``, as before it runs the command."""
    words = shlex.split(line, comments=True)
    assert words[0] == "asictl", line
    ctx = click.Context(main, info_name="asictl")
    command: click.Command = main
    words = words[1:]
    while isinstance(command, click.Group):
        name, sub, words = command.resolve_command(ctx, words)
        assert name is not None and sub is not None, line
        ctx, command = click.Context(sub, info_name=name, parent=ctx), sub
    command.make_context(ctx.info_name, words, parent=ctx.parent)


@pytest.mark.parametrize("path", sorted(SERVERS))
def test_the_examples_of_servers_parse(path: str) -> None:
    assert _ALL[path]
    for line in _ALL[path]:
        _parse(line)


def test_a_wrong_example_line_is_caught(tmp_path: Path) -> None:
    with pytest.raises(click.UsageError):
        _parse("asictl serve --no-such-option")
    with pytest.raises(AssertionError, match="exit 2"):
        _run(["asictl check no-such-file.asi"], _folder(tmp_path), tmp_path / "state")
    _run(["asictl check no-such-file.asi  # exit 2"], tmp_path / "work", tmp_path / "state")


def test_only_servers_are_left_unrun() -> None:
    assert set(_ALL) >= SERVERS | NEED_A_SERVED_BOARD
    assert len(SERVERS) <= 5
