"""``asictl debug``: the IL debugger, interactive (with readline history and Tab
completion) or scripted."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

import click

from asictl.cli.options import Duration, lib_option
from asictl.debug.debugger import WORD_BREAKS, DebugError, Debugger
from asictl.errors import ExitCode, UserError
from asictl.sim.scenario import MAX_TIME_MS
from asictl.sim.session import Invalid, prepare, scenario_for
from asictl.source import read_source

PROMPT = "(asictl) "


def _history_file() -> Path:
    state = os.environ.get("XDG_STATE_HOME") or os.path.join(os.path.expanduser("~"), ".local",
                                                             "state")
    return Path(os.environ.get("ASICTL_HISTORY", os.path.join(state, "asictl", "debug_history")))


@click.command()
@click.argument("program", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--scenario", "scenario_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Scenario to apply (default: PROGRAM's NAME.scenario.toml beside it).")
@click.option("--no-scenario", is_flag=True, help="Do not use the scenario beside the program.")
@click.option("--set", "sets", multiple=True, metavar='"OPERAND=VALUE"',
              help='Set an input or flag at time 0 (repeatable).')
@click.option("--duration", type=Duration(limit_ms=MAX_TIME_MS),
              help="Master time the session may run (default: the scenario's "
              "last step; 10s without a scenario).")
@click.option("--batch", type=click.Path(dir_okay=False, path_type=Path),
              help="Read the commands from this file ('-': standard input) instead of a "
              "terminal; each is echoed after the prompt.")
@lib_option
def debug(program: Path, scenario_path: Path | None, no_scenario: bool, sets: tuple[str, ...],
          duration: float | None, batch: Path | None, lib: tuple[str, ...]) -> None:
    """Debug PROGRAM at the IL level on an emulated master in virtual time.

    Breakpoints on IL lines (break 12, break blink.asi:12 if RLO=1), step, next,
    continue, cycle, time 100ms, print I 1.0 / FY 10 / T 0 / C 0 / RLO, set I 1.0=1.
    'help' lists the commands.

    Exit status: 0; 1 the program has errors, or with --batch a command was refused; 2
    bad input.

    \b
    Example:
      printf 'break 17\\ncontinue\\nprint Q 31.0\\n' | asictl debug demos/blink.asi --batch -
    """
    ctx = click.get_current_context()
    duration_ms = duration
    if scenario_path is None and not no_scenario and scenario_for(program).is_file():
        scenario_path = scenario_for(program)
    try:
        prepared = prepare(program, scenario_path, lib=lib, sets=sets, duration_ms=duration_ms,
                           allow_partial=True)
    except Invalid as exc:
        click.echo(exc.text, nl=False, err=True)
        ctx.exit(int(exc.exit_code))
    click.echo(prepared.notes, nl=False, err=True)
    if scenario_path is not None:
        click.echo(f"scenario {scenario_path}")
    try:
        debugger = Debugger(prepared, click.echo)
    except DebugError as exc:
        raise UserError(str(exc)) from None
    if batch is not None:
        _batch(debugger, batch)
        ctx.exit(int(ExitCode.FAILED if debugger.failed else ExitCode.OK))
    _interactive(debugger)


def _batch(debugger: Debugger, path: Path) -> None:
    for line in read_source(path).text.splitlines():
        command = line.partition("#")[0].strip()
        if not command:
            continue
        click.echo(f"{PROMPT}{command}")
        if not debugger.execute(command):
            return
    debugger.close()


#: The commands an empty line repeats, as gdb does: the ones that move the program on.
REPEATED = frozenset({"s", "step", "n", "next", "c", "continue", "cycle", "finish", "time"})


def _moves_on(command: str) -> bool:
    words = command.split()
    return bool(words) and words[0].lower() in REPEATED


class LineBuffer(Protocol):
    """What completion needs of readline: the line typed so far and where the cursor is."""

    def get_line_buffer(self) -> str: ...

    def get_endidx(self) -> int: ...


def completer(debugger: Debugger, line: LineBuffer) -> Callable[[str, int], str | None]:
    """readline's completer: asked with state 0, 1, ... for the matches of the word
    before the cursor until it answers None; the matches are the debugger's
    ``completions`` of the line up to the cursor, each with the space that follows a
    word (Python's readline adds none), but a file's ``count.asi:``, which its line
    number follows."""
    matches: list[str] = []

    def complete(text: str, state: int) -> str | None:
        if state == 0:
            found = debugger.completions(line.get_line_buffer()[:line.get_endidx()])
            matches[:] = [word if word.endswith(":") else f"{word} " for word in found]
        return matches[state] if state < len(matches) else None

    return complete


def _interactive(debugger: Debugger) -> None:
    history = _history_file()
    try:
        import readline
    except ImportError:  # pragma: no cover - every supported platform has it
        readline = None  # type: ignore[assignment]
    if readline is not None:
        with contextlib.suppress(OSError):
            readline.read_history_file(history)
        readline.set_history_length(1000)
        readline.set_completer_delims(WORD_BREAKS)
        readline.set_completer(completer(debugger, readline))
        # macOS's Python links libedit, which reads its own key bindings
        libedit = "libedit" in (readline.__doc__ or "")
        readline.parse_and_bind("bind ^I rl_complete" if libedit else "tab: complete")
    last = ""
    try:
        while True:
            try:
                command = input(PROMPT)
            except EOFError:
                click.echo()
                break
            except KeyboardInterrupt:
                click.echo()
                continue
            if command.strip():
                last = command
            elif _moves_on(last):
                command = last  # as gdb: Enter repeats the last command when it moved on
            if not debugger.execute(command):
                break
    finally:
        debugger.close()
        if readline is not None:
            with contextlib.suppress(OSError):
                history.parent.mkdir(parents=True, exist_ok=True)
                readline.write_history_file(history)
