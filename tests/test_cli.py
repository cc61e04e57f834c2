"""The command line as a whole: help, version, exit codes, no tracebacks."""

from __future__ import annotations

import subprocess
import sys

import click
import pytest
from click.testing import CliRunner

from asictl.cli import COMMANDS, main


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_command_loads_and_has_help(name: str):
    runner = CliRunner()
    result = runner.invoke(main, [name, "--help"])
    assert result.exit_code == 0, result.output
    command = main.get_command(click.Context(main), name)
    assert command is not None and command.help and len(command.help) > 40


def test_top_level_help_lists_commands_without_importing_them():
    code = (
        "import sys; from click.testing import CliRunner; from asictl.cli import main;"
        "r = CliRunner().invoke(main, ['--help']); print(r.output);"
        "print('LOADED' if any(m.startswith('asictl.cli.') for m in sys.modules) else 'LAZY')"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True).stdout
    for name in COMMANDS:
        assert f"  {name}" in out
    assert out.strip().endswith("LAZY")


def test_unknown_command_exits_2():
    assert CliRunner().invoke(main, ["frobnicate"]).exit_code == 2


def test_version():
    result = CliRunner().invoke(main, ["--version"])
    assert result.exit_code == 0 and "asictl, version" in result.output


def test_internal_errors_are_labelled_as_bugs_without_traceback(monkeypatch):
    import asictl.cli.check as check_module

    def boom(*args, **kwargs):
        raise RuntimeError("kaput")

    monkeypatch.setattr(check_module, "check_program_file", boom)
    monkeypatch.delenv("ASICTL_DEBUG", raising=False)
    result = CliRunner().invoke(main, ["check", "demos/blink.asi"])
    assert result.exit_code == 3
    assert "internal error (this is a bug in asictl" in result.stderr
    assert "Traceback" not in result.output


def test_the_console_script_freezes_the_collector_at_exit(monkeypatch) -> None:
    """``run`` (the console script) exits as ``main`` does and freezes the collector's
    view first, so that the interpreter's last collection skips what the command left."""
    import gc

    from asictl import cli

    frozen = []
    monkeypatch.setattr(gc, "freeze", lambda: frozen.append(True))
    monkeypatch.setattr(sys, "argv", ["asictl", "check", "--help"])
    with pytest.raises(SystemExit) as exit_info:
        cli.run()
    assert exit_info.value.code == 0
    assert frozen == [True]
