"""One run split among N CI jobs by file: ``--shard I/N`` of ``test``, ``mutate`` and
``prove``.

Each job of a CI matrix lists the same files and keeps its own share, so the jobs must
agree on the split without talking to each other: the files are sorted by their path
relative to the folder they all sit in (so a checkout's place on the runner does not
matter) and dealt out in turn, the first to shard 1, the second to shard 2, and so on.
Every file is then in exactly one shard, and the shards differ in size by one file at
most. A file named twice is one file: both names go to the same shard. The reports the
shards write are put back together by ``asictl report merge`` (docs/testing.md).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path, PurePath
from typing import TypeVar

#: GitLab's ``parallel:`` jobs: the job's number (from 1) and how many there are.
INDEX_VARIABLE, TOTAL_VARIABLE = "CI_NODE_INDEX", "CI_NODE_TOTAL"

_Item = TypeVar("_Item")


class ShardError(ValueError):
    """A ``--shard`` value that names no share of the files."""


@dataclass(frozen=True)
class Shard:
    """Shard ``index`` (1-based) of ``total``."""

    index: int
    total: int

    def __str__(self) -> str:
        return f"{self.index}/{self.total}"

    @classmethod
    def parse(cls, text: str, environ: Mapping[str, str] | None = None) -> Shard:
        """``I/N``, or ``auto``: GitLab's ``CI_NODE_INDEX``/``CI_NODE_TOTAL`` when set,
        else the whole (1/1: a job that is not one of a ``parallel:`` set)."""
        if text.strip().lower() == "auto":
            env = os.environ if environ is None else environ
            index, total = env.get(INDEX_VARIABLE), env.get(TOTAL_VARIABLE)
            if index is None and total is None:
                return cls(1, 1)
            if index is None or total is None:
                missing = INDEX_VARIABLE if index is None else TOTAL_VARIABLE
                raise ShardError(f"'auto' needs both {INDEX_VARIABLE} and {TOTAL_VARIABLE}; "
                                 f"{missing} is not set")
            return cls._checked(index, total, f"{INDEX_VARIABLE}/{TOTAL_VARIABLE} "
                                f"'{index}/{total}'")
        index, slash, total = text.partition("/")
        if not slash:
            raise ShardError(f"'{text}' is not I/N (e.g. 1/4) or auto")
        return cls._checked(index, total, f"'{text}'")

    @classmethod
    def _checked(cls, index: str, total: str, shown: str) -> Shard:
        try:
            i, n = int(index.strip()), int(total.strip())
        except ValueError:
            raise ShardError(f"{shown}: I and N are whole numbers, e.g. 1/4") from None
        if n < 1:
            raise ShardError(f"{shown}: N is at least 1")
        if not 1 <= i <= n:
            raise ShardError(f"{shown}: I counts from 1 to N ({n})")
        return cls(i, n)


def keys(paths: Sequence[str | PurePath]) -> list[str]:
    """Each path relative to the folder all of them sit in, with forward slashes: what
    every job sees alike wherever the checkout is."""
    if not paths:
        return []
    absolute = [os.path.abspath(p) for p in paths]
    try:
        root = os.path.commonpath(absolute)
    except ValueError:  # paths on two drives share no folder
        return [PurePath(p).as_posix() for p in absolute]
    return [PurePath(os.path.relpath(p, root)).as_posix() for p in absolute]


def shard_of(paths: Sequence[str | PurePath], total: int) -> list[int]:
    """The shard (1-based) of each path, dealt out in the order of ``keys``."""
    named = keys(paths)
    turn = {key: n % total + 1 for n, key in enumerate(sorted(set(named)))}
    return [turn[key] for key in named]


def select(items: Sequence[_Item], paths: Sequence[str | Path], shard: Shard) -> list[_Item]:
    """The items whose path (``paths[i]`` is the path of ``items[i]``) falls in
    ``shard``, in their given order."""
    return [item for item, n in zip(items, shard_of(paths, shard.total), strict=True)
            if n == shard.index]
