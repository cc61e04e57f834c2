"""Options several commands share, spelled and explained once."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TypeVar

import click

from asictl.readers.shard import Shard, ShardError, select
from asictl.readers.units import (
    Cycles,
    UnitError,
    format_duration,
    parse_cycles,
    parse_duration,
)

_Command = TypeVar("_Command", bound=Callable[..., object])
_Item = TypeVar("_Item")

#: ``--lib DIR`` (repeatable): where the loader looks for function-block files besides the
#: program's folder; every command that builds a program takes it.
lib_option = click.option(
    "--lib", "lib", multiple=True, type=click.Path(file_okay=False),
    help="Also look for function-block files here (repeatable; also $ASICTL_LIB).",
)


class ShardSpec(click.ParamType[Shard]):
    """``I/N`` or ``auto`` (GitLab's ``CI_NODE_INDEX``/``CI_NODE_TOTAL``), read by
    ``asictl.readers.shard``; a value that names no shard is a usage error."""

    name = "I/N"

    def convert(self, value: object, param: click.Parameter | None,
                ctx: click.Context | None) -> Shard:
        if isinstance(value, Shard):
            return value
        try:
            return Shard.parse(str(value))
        except ShardError as exc:
            self.fail(str(exc), param, ctx)


def shard_option(what: str) -> Callable[[_Command], _Command]:
    """``--shard I/N`` of a command that runs one job of a CI matrix: its share of
    ``what`` (docs/testing.md, "Shards")."""
    return click.option(
        "--shard", type=ShardSpec(), default=None, metavar="I/N",
        help=f"Run only shard I of N (1-based) of the {what}, split by path, so that N "
        "CI jobs run each once; 'auto' reads CI_NODE_INDEX/CI_NODE_TOTAL (GitLab). "
        "'asictl report merge' joins the shards' reports.",
    )


def take_shard(items: Sequence[_Item], paths: Sequence[str | Path], shard: Shard | None,
               what: str) -> list[_Item]:
    """The items (``paths[i]`` the path of ``items[i]``) of ``shard``, all without one. A
    shard left with none (more shards than files) says so and goes on: its job still
    passes and writes its (empty) reports for the merge."""
    if shard is None:
        return list(items)
    mine = select(items, paths, shard)
    if not mine:
        click.echo(f"asictl: note: shard {shard} has no {what} ({len(items)} in all)",
                   err=True)
    return mine


class Duration(click.ParamType[float]):
    """A time on the command line, in milliseconds: a number with its unit (``250ms``,
    ``10s``, ``2min``, ``1h``), read by ``readers.units`` as every file's time is.

    A bare number is refused with both readings ("give a unit: 16ms or 16s"): ``sim
    --duration 16`` once meant 16 s while a scenario's 16 meant 16 ms, so no bare
    number is guessed (docs/simulation.md, "Durations")."""

    name = "duration"

    def __init__(self, *, limit_ms: float | None = None, positive: bool = False,
                 least_ms: float = 0.0) -> None:
        self.limit_ms = limit_ms
        self.positive = positive
        self.least_ms = least_ms

    def convert(self, value: object, param: click.Parameter | None,
                ctx: click.Context | None) -> float:
        if isinstance(value, float):  # a default already in milliseconds
            return value
        try:
            ms = parse_duration(str(value), limit_ms=self.limit_ms)
        except UnitError as exc:
            self.fail(str(exc), param, ctx)
        if self.positive and ms <= 0:
            self.fail(f"'{value}' is no time at all", param, ctx)
        if ms < self.least_ms:
            self.fail(f"'{value}' is shorter than {format_duration(self.least_ms)}", param, ctx)
        return ms


class CycleCount(click.ParamType[Cycles]):
    """A number of program cycles: a whole number (``25``) is cycles, a time with its
    unit (``25s``) is turned into cycles with the program's cycle time (``--depth``)."""

    name = "cycles"

    def __init__(self, most: int) -> None:
        self.most = most

    def convert(self, value: object, param: click.Parameter | None,
                ctx: click.Context | None) -> Cycles:
        if isinstance(value, Cycles):
            return value
        try:
            found = parse_cycles(str(value))
        except UnitError as exc:
            self.fail(str(exc), param, ctx)
        if found.count is not None and found.count > self.most:
            self.fail(f"{found.count} is more than {self.most} cycles", param, ctx)
        return found


def one_of(**given: bool) -> str | None:
    """The one flag given of flags that contradict each other (``--start``, ``--stop``),
    named as its keyword, or None; two are a usage error, never "the last one wins"."""
    chosen = [name for name, on in given.items() if on]
    if len(chosen) > 1:
        raise click.UsageError(" and ".join("--" + name.replace("_", "-") for name in chosen)
                               + " contradict each other: give one")
    return chosen[0] if chosen else None
class Number(click.FloatRange):
    """A finite number between two bounds. click's ``FloatRange`` lets ``nan`` through
    (every comparison with it is false), so ``--min-score nan`` would never fail; this
    refuses ``nan`` and the infinities before the range is checked."""

    name = "number"

    def convert(self, value: object, param: click.Parameter | None,
                ctx: click.Context | None) -> float:
        number = click.FLOAT.convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        result: float = super().convert(number, param, ctx)
        return result


#: ``--coverage-fail-under`` of ``test`` and ``report merge`` (the shards' coverage).
coverage_fail_under_option = click.option(
    "--coverage-fail-under", type=Number(0, 100), metavar="PERCENT",
    help="Exit 1 when less than PERCENT of the statement lines ran.",
)
#: ``--min-score`` of ``mutate`` and ``report merge`` (the shards' mutants).
min_score_option = click.option(
    "--min-score", type=Number(0, 100), metavar="PERCENT",
    help="Exit 1 when the mutation score is below PERCENT.",
)


def below_bar(what: str, share: float, bar: float | None, option: str, digits: int) -> bool:
    """Whether ``share`` (percent) is below the ``bar`` an ``option`` such as
    ``--min-score`` set; if so, says it on standard error with ``digits`` decimals."""
    if bar is None or share >= bar:
        return False
    click.echo(f"asictl: error: {what} {share:.{digits}f}% is below {option} {bar:g}%",
               err=True)
    return True


def apply_options(command: _Command,
                  options: Sequence[Callable[[_Command], _Command]]) -> _Command:
    """``command`` with ``options`` added, listed in ``--help`` in the order given (a
    decorator applied last comes first, so they are applied in reverse)."""
    for option in reversed(options):
        command = option(command)
    return command
