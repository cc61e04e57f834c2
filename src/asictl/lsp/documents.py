"""The editor's open files and what the checks say about them.

An editor shows buffers that may differ from the files on disk, and function-block files
that only mean something as part of the main program that calls them. The store keeps the
open buffers; ``analyse`` checks a file the way ``asictl check`` does, with the same front
end, reading block files from the open buffers first and from disk otherwise. A block file
is analysed as part of its main program: an open one that calls it, or else an ``.asi``
file beside it whose [DECL] names it; only when there is none is it checked on its own.

Each analysis remembers every file its check asked for (read or looked for) and the
version of each, so a change to one buffer drops only the analyses that read it: with
hundreds of open files, typing in one re-checks one program, not all of them. The store
may be read from several threads (the server checks off its message loop): the buffers
are copied under a lock into a ``View`` and analysed there, and an analysis is kept only
if none of the files it read changed meanwhile; a thread that needs an analysis another
is making of the same texts waits for that one rather than make it twice. Which main
program calls a block is taken, for a request, from the last analysis of each program,
current or not: a hover in a small file must not wait for the check of a megabyte
program open beside it that has just changed (the checker, which groups the files for
diagnostics, asks afresh).
"""

from __future__ import annotations

import os
import re
import threading
from collections.abc import Iterable, Mapping
from concurrent.futures import Future
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

from asictl.diagnostics import Diagnostic
from asictl.errors import UserError
from asictl.il import ast
from asictl.il.checks import CheckResult, check_source
from asictl.il.loader import fb_declarations
from asictl.il.parser import parse
from asictl.il.references import ReferenceIndex, build_index
from asictl.source import SourceText, from_string, read_source


def normal(path: str) -> str:
    """One spelling per file, so that buffers, spans and block look-ups agree."""
    return os.path.normpath(path)


_SURROGATE = re.compile("[\ud800-\udfff]")


def clean(text: str) -> str:
    """The text with each lone UTF-16 surrogate (JSON allows ``"\\ud800"``, no file
    can hold one) as U+FFFD: one code unit for one, so every position stays where it was,
    and nothing that later encodes the text (a file, an answer) fails on it."""
    return _SURROGATE.sub("\ufffd", text)


@dataclass(eq=False)
class Analysis:
    """A checked program: the main file, its blocks, their diagnostics and references."""

    main: str
    result: CheckResult
    index: ReferenceIndex
    #: every file the check asked for, with its version then (0: not an open buffer)
    reads: Mapping[str, int] = field(default_factory=dict)
    _lines: dict[str, list[str]] = field(default_factory=dict, init=False, repr=False)

    @cached_property
    def files(self) -> list[str]:
        return list(self.result.program.sources)

    def diagnostics(self, file: str) -> list[Diagnostic]:
        return [d for d in self.result.diagnostics if (d.span.file if d.span else self.main)
                == file]

    def module(self, file: str) -> ast.Module | None:
        return next((m for m in self.result.program.modules() if m.file == file), None)

    def text(self, file: str) -> str:
        source = self.result.program.sources.get(file)
        return source.text if source else ""

    def lines(self, file: str) -> list[str]:
        """The lines of a file as this analysis read it, split once: spans convert to
        editor positions against these, however many diagnostics there are."""
        if file not in self._lines:
            self._lines[file] = self.text(file).split("\n")
        return self._lines[file]


@dataclass
class Documents:
    """Open buffers by path, and the analyses made of them that are still current."""

    lib: tuple[str, ...] = ()
    buffers: dict[str, str] = field(default_factory=dict)
    #: path -> how many times its buffer was opened, changed or closed
    _versions: dict[str, int] = field(default_factory=dict)
    _analyses: dict[str, Analysis] = field(default_factory=dict)
    _lines: dict[str, list[str]] = field(default_factory=dict)
    #: main program -> the files its last analysis read
    _files: dict[str, frozenset[str]] = field(default_factory=dict)
    #: main program -> the analysis a thread is making, and of which buffer versions
    _making: dict[str, tuple[dict[str, int], Future[Analysis]]] = field(default_factory=dict)
    _lock: threading.Lock = field(default_factory=threading.Lock)

    # ------------------------------------------------------------------ buffers

    def open(self, path: str, text: str) -> None:
        self._set(normal(path), clean(text))

    change = open

    def close(self, path: str) -> None:
        self._set(normal(path), None)

    def _set(self, path: str, text: str | None) -> None:
        with self._lock:
            if text is None:
                self.buffers.pop(path, None)
            else:
                self.buffers[path] = text
            self._versions[path] = self._versions.get(path, 0) + 1
            self._lines.pop(path, None)
            self._analyses = {main: a for main, a in self._analyses.items()
                              if path not in a.reads}

    def reload(self) -> None:
        """Forget the analyses that read a file from disk (one may have been saved)."""
        with self._lock:
            self._analyses = {main: a for main, a in self._analyses.items()
                              if all(path in self.buffers for path in a.reads)}

    def source(self, path: str | Path) -> SourceText:
        """A file's text: its open buffer, else the file on disk (``UserError`` if neither)."""
        with self._lock:
            text = self.buffers.get(normal(str(path)))
        return _source(normal(str(path)), text)

    def text(self, path: str) -> str:
        try:
            return self.source(path).text
        except UserError:
            return ""

    def lines(self, path: str) -> list[str]:
        """The lines of a buffer (or file), split once per version of an open buffer."""
        path = normal(path)
        with self._lock:
            found = self._lines.get(path)
        if found is None:
            found = self.text(path).split("\n")
            with self._lock:
                if path in self.buffers:
                    self._lines[path] = found
        return found

    # ----------------------------------------------------------------- analysis

    def view(self) -> View:
        """The buffers as they are now, to analyse without holding the lock."""
        with self._lock:
            return View(self, dict(self.buffers), dict(self._versions))

    def analyse(self, path: str) -> Analysis:
        """The analysis that covers ``path``: its main program's, or its own if no main
        program calls it."""
        return self.view().analyse(path)

    def analyse_open(self) -> list[Analysis]:
        """One analysis per main program of the open buffers."""
        return self.view().analyse_open()

    def cached(self, path: str) -> Analysis | None:
        """``analyse(path)`` if that needs no check (every analysis it takes is kept)."""
        try:
            return self.view().analyse(path, check=False)
        except _NotCached:
            return None

    def is_current(self, analysis: Analysis) -> bool:
        """Whether no file the analysis read has changed since."""
        with self._lock:
            return _unchanged(analysis.reads, self._versions)

    def _kept(self, main: str, versions: Mapping[str, int]) -> Analysis | None:
        with self._lock:
            found = self._analyses.get(main)
        if found is not None and _unchanged(found.reads, versions):
            return found
        return None

    def _keep(self, analysis: Analysis) -> None:
        with self._lock:
            self._files[analysis.main] = frozenset(analysis.files)
            if _unchanged(analysis.reads, self._versions):
                self._analyses[analysis.main] = analysis


def _unchanged(reads: Mapping[str, int], versions: Mapping[str, int]) -> bool:
    """Whether every file an analysis read is still at the version it read (a file never
    opened is at version 0), so that the analysis still holds."""
    return all(versions.get(path, 0) == version for path, version in reads.items())


class _NotCached(Exception):
    """An analysis ``Documents.cached`` would have had to make."""


@dataclass
class View:
    """The buffers at one moment: analyses made here read only this copy, so another
    thread may change the buffers meanwhile."""

    documents: Documents
    buffers: dict[str, str]
    versions: dict[str, int]
    check: bool = True

    def analyse(self, path: str, *, check: bool = True) -> Analysis:
        self.check = check
        path = normal(path)
        analysis = self._analyse_main(self.main_of(path))
        return analysis if path in analysis.files else self._analyse_main(path)

    def analyse_open(self) -> list[Analysis]:
        """``main_of`` for every buffer, in time linear in their number: each open main
        program is analysed once, and who reads which file is looked up from that."""
        readers: dict[str, list[str]] = {}
        for other in self.buffers:
            if not _is_block_file(other):
                for file in self._analyse_main(other).files:
                    readers.setdefault(file, []).append(other)
        mains = dict.fromkeys(
            next((m for m in readers.get(path, ()) if m != path), None)
            or self._unread_main(path) for path in self.buffers)
        return [self._analyse_main(main) for main in mains]

    def main_of(self, path: str) -> str:
        """The main program ``path`` is analysed in: an open one that reads it (by its
        last analysis, current or not, so that a request does not wait for another
        program's check), else a neighbour that declares it, else itself."""
        for other in self.buffers:
            if other != path and not _is_block_file(other) and path in self._files_of(other):
                return other
        return self._unread_main(path)

    def _unread_main(self, path: str) -> str:
        """The main program of a file no open program reads: for a block, an ``.asi``
        file beside it that declares it; else the file itself."""
        if _is_block_file(path):
            for candidate in self._neighbours(path):
                if self._declares(candidate, path):
                    return candidate
        return path

    def _files_of(self, main: str) -> frozenset[str]:
        """The files ``main``'s last analysis read; a program not analysed yet is now."""
        with self.documents._lock:
            known = self.documents._files.get(main)
        return known if known is not None else frozenset(self._analyse_main(main).files)

    def _analyse_main(self, main: str) -> Analysis:
        kept = self.documents._kept(main, self.versions)
        if kept is not None:
            return kept
        if not self.check:
            raise _NotCached(main)
        documents = self.documents
        with documents._lock:
            making = documents._making.get(main)
            if making is not None and making[0] == self.versions:
                waiting = making[1]  # another thread checks the same texts: wait for it
            else:
                waiting = None
                made: Future[Analysis] = Future()
                documents._making[main] = (self.versions, made)
        if waiting is not None:
            return waiting.result()
        try:
            analysis = self._make(main)
        except BaseException as exc:
            made.set_exception(exc)
            raise
        else:
            made.set_result(analysis)
            return analysis
        finally:
            with documents._lock:
                if documents._making.get(main, (None, None))[1] is made:
                    del documents._making[main]

    def _make(self, main: str) -> Analysis:
        reads: dict[str, int] = {}

        def read(path: str | Path) -> SourceText:
            name = normal(str(path))
            reads[name] = self.versions.get(name, 0)
            return _source(name, self.buffers.get(name))

        def exists(path: Path) -> bool:
            name = normal(str(path))
            reads[name] = self.versions.get(name, 0)
            return name in self.buffers or path.is_file()

        try:
            source = read(main)
        except UserError:
            source = from_string(main, "")
        result = check_source(source, lib=self.documents.lib, read=read, exists=exists)
        analysis = Analysis(main, result, build_index(result.program), reads)
        self.documents._keep(analysis)
        return analysis

    def _neighbours(self, path: str) -> Iterable[str]:
        folder = Path(path).parent
        found = {normal(str(p)) for p in folder.glob("*") if p.suffix.lower() == ".asi"}
        found |= {p for p in self.buffers if Path(p).parent == folder and not _is_block_file(p)}
        return sorted(found)

    def _declares(self, main: str, block: str) -> bool:
        """Whether ``main``'s [DECL] names the file ``block`` (as DOS did: in any case)."""
        try:
            module, _ = parse(_source(main, self.buffers.get(main)))
        except UserError:
            return False
        name = Path(block).name.casefold()
        return any(Path(d.file).name.casefold() == name for d in fb_declarations(module))


def _source(name: str, buffer: str | None) -> SourceText:
    """An open buffer's text, else the file's on disk (``UserError`` if neither)."""
    if buffer is not None:
        return from_string(name, buffer)
    source = read_source(name)
    return SourceText(name, source.text, source.raw)


def _is_block_file(path: str) -> bool:
    return Path(path).suffix.lower() == ".fb"
