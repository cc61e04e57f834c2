"""Mutation results kept between runs: a re-run judges again only what has changed.

A mutant's verdict depends on its program, the change, the scenarios that test the
program, the limits it ran under and asictl itself; nothing else reaches the worker
that judges it. So each program's results are kept under a key made of all of that: a
hash of the program's source texts (its function blocks and included files too), the
path and text of each scenario that tests it and of the symbol table beside the
program, the ``--timeout`` and ``--proof-timeout`` given, whether the prover is there,
asictl's version and a hash of asictl's own code (an upgrade, or a changed checkout,
judges everything again). Plant models are tables inside the scenario, so its text
covers them. Within a program's results each mutant is known by its place and change.

One file a program (named by a hash of its path) holds the key and the results; a
change to a program or to one of its scenarios makes its key differ, so only that
program's mutants run again and the file is replaced when they have. Files are written
atomically (asictl.files), and a file is used only when its whole shape is as written
here, down to each verdict's name: a corrupt, foreign or older file is ignored (its
program's mutants simply run), never trusted.

Not kept: a mutant whose worker died (the cause was outside the program) or whose
judging failed inside asictl. A survivor whose proof ran out of time is kept, under its
``--proof-timeout``: a longer one judges it again.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from asictl import __version__
from asictl.errors import UserError
from asictl.files import cache_home, write_atomic
from asictl.observe.symbols import SymbolTable
from asictl.source import symbols_path

#: What a cache file says it is, and the version of its layout.
KIND = "asictl mutate results"
FORMAT = 1
#: The verdicts a cache file may hold (``died`` never is).
KEPT = frozenset({"killed", "timeout", "survived", "equivalent", "invalid"})
#: The detail of a mutant whose judging failed inside asictl (``quality.mutate``).
INTERNAL = "internal error: "
#: A cache file larger than this is not read (a program has hundreds of mutants).
LARGEST_BYTES = 16 * 1024 * 1024


def default_directory() -> Path | None:
    """``mutate`` in asictl's cache folder (``files.cache_home``); None without one."""
    home = cache_home()
    return None if home is None else home / "mutate"


@functools.cache
def code_hash() -> str:
    """A hash of asictl's own modules and grammars, as installed or checked out."""
    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*")):
        if path.suffix in (".py", ".lark") and path.is_file():
            digest.update(path.relative_to(root).as_posix().encode() + b"\0")
            digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


def _text(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except OSError:  # gone since it was read: the key cannot match an earlier one
        return b"\0unreadable\0" + os.urandom(16)


def target_key(program: Path, texts: dict[str, str], scenarios: Iterable[Path],
               settings: object, names: SymbolTable | None = None) -> str:
    """The key of one program's results: everything its verdicts depend on (``names``:
    the table that names the operands of their notes, ``mutate --symbols``)."""
    digest = hashlib.sha256()

    def part(data: str | bytes) -> None:
        raw = data.encode() if isinstance(data, str) else data
        digest.update(len(raw).to_bytes(8, "little") + raw)

    for text in (KIND, str(FORMAT), __version__, code_hash(), repr(settings),
                 str(program.resolve())):
        part(text)
    for name, text in sorted(texts.items()):
        part(name)
        part(text)
    symbols = symbols_path(program)
    part(_text(symbols) if symbols.is_file() else b"")
    part(repr(sorted(names.entries.items())) if names is not None else "")
    for scenario in scenarios:
        part(str(scenario.resolve()))
        part(_text(scenario))
    return digest.hexdigest()


@dataclass(frozen=True)
class Kept:
    """A verdict read back: its name and detail."""

    verdict: str
    detail: str


@dataclass
class Cache:
    """A folder of kept results; ``problems`` collects what could not be written."""

    directory: Path
    problems: list[str] = field(default_factory=list)

    def _file(self, program: Path) -> Path:
        name = hashlib.sha256(str(program.resolve()).encode()).hexdigest()[:32]
        return self.directory / f"{name}.json"

    def load(self, program: Path, key: str) -> dict[str, Kept]:
        """The results kept for ``program`` under ``key`` by mutant; none when there is
        no file, it was written under another key or its shape is not this module's."""
        path = self._file(program)
        try:
            if path.is_symlink() or path.stat().st_size > LARGEST_BYTES:
                return {}
            document = json.loads(path.read_bytes())
        except (OSError, ValueError, RecursionError):
            return {}
        return _kept(document, key) or {}

    def store(self, program: Path, key: str, results: Iterable[tuple[str, str, str]]) -> None:
        """Keep ``(mutant, verdict, detail)`` for ``program`` under ``key``, those that
        may be kept; a failure to write is noted in ``problems``, never raised (the run
        it would have spared a second time has still been made)."""
        rows = [{"mutant": mutant, "verdict": verdict, "detail": detail}
                for mutant, verdict, detail in results
                if verdict in KEPT and not detail.startswith(INTERNAL)]
        document = {"kind": KIND, "format": FORMAT, "key": key,
                    "program": str(program.resolve()), "results": rows}
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            write_atomic(self._file(program), json.dumps(document, indent=1) + "\n",
                         follow_links=False)
        except (OSError, UserError) as exc:
            self.problems.append(f"{self.directory}: results not kept: {exc}")


def _kept(document: Any, key: str) -> dict[str, Kept] | None:
    """The results of a cache file read as JSON, or None unless every part of it has
    the shape ``store`` writes (and its key is ``key``)."""
    if not isinstance(document, dict) or document.get("kind") != KIND \
            or document.get("format") != FORMAT or document.get("key") != key \
            or not isinstance(document.get("results"), list):
        return None
    kept: dict[str, Kept] = {}
    for row in document["results"]:
        if not isinstance(row, dict) or set(row) != {"mutant", "verdict", "detail"}:
            return None
        mutant, verdict, detail = row["mutant"], row["verdict"], row["detail"]
        if not (isinstance(mutant, str) and isinstance(detail, str) and verdict in KEPT) \
                or mutant in kept or detail.startswith(INTERNAL):
            return None
        kept[mutant] = Kept(verdict, detail)
    return kept
