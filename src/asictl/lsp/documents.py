"""The editor's open files and what the checks say about them.

An editor shows buffers that may differ from the files on disk, and function-block files
that only mean something as part of the main program that calls them. The store keeps the
open buffers; ``analyse`` checks a file the way ``asictl check`` does, with the same front
end, reading block files from the open buffers first and from disk otherwise. A block file
is analysed as part of its main program: an open one that calls it, or else an ``.asi``
file beside it whose [DECL] names it; only when there is none is it checked on its own.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass, field
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


@dataclass
class Analysis:
    """A checked program: the main file, its blocks, their diagnostics and references."""

    main: str
    result: CheckResult
    index: ReferenceIndex

    @property
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


@dataclass
class Documents:
    """Open buffers by path, and the analyses made of them since the last change."""

    lib: tuple[str, ...] = ()
    buffers: dict[str, str] = field(default_factory=dict)
    _analyses: dict[str, Analysis] = field(default_factory=dict)

    # ------------------------------------------------------------------ buffers

    def open(self, path: str, text: str) -> None:
        self.buffers[normal(path)] = text
        self._analyses.clear()

    change = open

    def close(self, path: str) -> None:
        self.buffers.pop(normal(path), None)
        self._analyses.clear()

    def source(self, path: str | Path) -> SourceText:
        """A file's text: its open buffer, else the file on disk (``UserError`` if neither)."""
        name = normal(str(path))
        if name in self.buffers:
            return from_string(name, self.buffers[name])
        source = read_source(name)
        return SourceText(name, source.text, source.raw)

    def exists(self, path: Path) -> bool:
        return normal(str(path)) in self.buffers or path.is_file()

    def text(self, path: str) -> str:
        try:
            return self.source(path).text
        except UserError:
            return ""

    # ----------------------------------------------------------------- analysis

    def analyse(self, path: str) -> Analysis:
        """The analysis that covers ``path``: its main program's, or its own if no main
        program calls it."""
        path = normal(path)
        analysis = self._analyse_main(self.main_of(path))
        return analysis if path in analysis.files else self._analyse_main(path)

    def analyse_open(self) -> list[Analysis]:
        """One analysis per main program of the open buffers."""
        mains = dict.fromkeys(self.main_of(path) for path in list(self.buffers))
        return [self._analyse_main(main) for main in mains]

    def main_of(self, path: str) -> str:
        for other in self.buffers:
            if other != path and not _is_block_file(other):
                analysis = self._analyse_main(other)
                if path in analysis.files:
                    return other
        if _is_block_file(path):
            for candidate in self._neighbours(path):
                if self._declares(candidate, path):
                    return candidate
        return path

    def _analyse_main(self, main: str) -> Analysis:
        if main not in self._analyses:
            try:
                source = self.source(main)
            except UserError:
                source = from_string(main, "")
            result = check_source(source, lib=self.lib, read=self.source, exists=self.exists)
            self._analyses[main] = Analysis(main, result, build_index(result.program))
        return self._analyses[main]

    def _neighbours(self, path: str) -> Iterable[str]:
        folder = Path(path).parent
        found = {normal(str(p)) for p in folder.glob("*") if p.suffix.lower() == ".asi"}
        found |= {p for p in self.buffers if Path(p).parent == folder and not _is_block_file(p)}
        return sorted(found)

    def _declares(self, main: str, block: str) -> bool:
        """Whether ``main``'s [DECL] names the file ``block`` (as DOS did: in any case)."""
        try:
            module, _ = parse(self.source(main))
        except UserError:
            return False
        name = Path(block).name.casefold()
        return any(Path(d.file).name.casefold() == name for d in fb_declarations(module))


def _is_block_file(path: str) -> bool:
    return Path(path).suffix.lower() == ".fb"
