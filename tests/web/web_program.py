"""A program on an emulated board for the web tests: its symbols name an input and the
output the program drives from it, its comments are hostile HTML, and a flag it toggles
every cycle keeps the page updated as fast as the server pushes."""

from __future__ import annotations

from pathlib import Path

from click.testing import CliRunner

from asictl.cli import main

HOSTILE = "<img src=x onerror=alert(1)><script>alert(2)</script>"
PROGRAM = f"""\
[SETUP]
1: iiii, 0

[PROGRAM]
        L   KB 42
        T   FY 12       ; {HOSTILE}
        A   I 1.0       ; the start button
        =   Q 1.0       ; the lamp follows it
        AN  F 1.0       ; a flag that changes every cycle: the page is updated all the time
        =   F 1.0
        BE
"""
SYMBOLS = 'Start = "I 1.0"\nLamp = "Q 1.0"\nAnswer = "FY 12"\n'
TOKEN = "correct-horse-battery-staple"


def downloaded(state: Path) -> Path:
    """``state`` (0700) with the program downloaded and started."""
    state.chmod(0o700)
    source = state / "lamp.asi"
    source.write_text(PROGRAM)
    (state / "lamp.symbols.toml").write_text(SYMBOLS)
    result = CliRunner().invoke(
        main, ["download", str(source), "--start", "--state-dir", str(state)]
    )
    assert result.exit_code == 0, result.output
    return state
