"""The language server: pygls wiring between the editor and the modules of this package.

Everything the server knows comes from the front end that ``asictl check`` uses
(``documents``), so its diagnostics are exactly the command's. This module only converts:
LSP positions (0-based, counted in the editor's code units, UTF-16 by default) to the
front end's 1-based lines and character columns and back, and results to LSP types.
"""

from __future__ import annotations

import asyncio
import re
from collections.abc import Sequence
from pathlib import Path

from lsprotocol import types as lsp
from pygls import uris
from pygls.lsp.server import LanguageServer

from asictl import __version__
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity, Span
from asictl.il.format import FormatError, format_text
from asictl.lsp import completion, hover, navigation
from asictl.lsp.documents import Documents, normal

#: How long the server waits after the last change before it checks again.
DEBOUNCE_SECONDS = 0.3

_LINE_ENDS = re.compile(r"\r\n|\r|\n")

_SEVERITIES = {
    Severity.ERROR: lsp.DiagnosticSeverity.Error,
    Severity.WARNING: lsp.DiagnosticSeverity.Warning,
    Severity.NOTE: lsp.DiagnosticSeverity.Information,
}
_COMPLETION_KINDS = {
    "keyword": lsp.CompletionItemKind.Keyword,
    "operand": lsp.CompletionItemKind.Operator,
    "slave": lsp.CompletionItemKind.Value,
    "variable": lsp.CompletionItemKind.Variable,
    "label": lsp.CompletionItemKind.Reference,
    "block": lsp.CompletionItemKind.Function,
    "section": lsp.CompletionItemKind.Module,
    "option": lsp.CompletionItemKind.Property,
    "value": lsp.CompletionItemKind.EnumMember,
}
_SYMBOL_KINDS = {
    "section": lsp.SymbolKind.Namespace,
    "segment": lsp.SymbolKind.Struct,
    "label": lsp.SymbolKind.Key,
    "slave": lsp.SymbolKind.Object,
    "declaration": lsp.SymbolKind.Variable,
}


class AsiLanguageServer(LanguageServer):
    """The server and its state: the open documents and what was last published."""

    def __init__(self, lib: Sequence[str] = ()) -> None:
        super().__init__("asictl", __version__)
        self.documents = Documents(lib=tuple(lib))
        #: path -> the URI the editor uses for it
        self.uris: dict[str, str] = {}
        self.published: set[str] = set()
        self.pending: asyncio.TimerHandle | None = None

    # ------------------------------------------------------------ paths and positions

    def path(self, uri: str) -> str:
        """The file a URI names; a URI that names no file (untitled:1) stands for itself."""
        path = uris.to_fs_path(uri) if uris.uri_scheme(uri) == "file" else None
        if path is None:
            return uri
        path = normal(path)
        self.uris.setdefault(path, uri)
        return path

    def uri(self, path: str) -> str:
        if path in self.uris:
            return self.uris[path]
        if not Path(path).is_absolute():
            return path  # the editor's own URI of a buffer that is no file
        return uris.from_fs_path(path) or path

    def lines(self, path: str) -> list[str]:
        return _LINE_ENDS.split(self.documents.text(path))

    def _units(self, text: str) -> int:
        encoding = self.workspace.position_encoding
        if encoding == lsp.PositionEncodingKind.Utf8:
            return len(text.encode("utf-8"))
        if encoding == lsp.PositionEncodingKind.Utf32:
            return len(text)
        return len(text.encode("utf-16-le")) // 2

    def position(self, path: str, line: int, column: int) -> lsp.Position:
        """A front-end position (1-based, characters) as an LSP position."""
        lines = self.lines(path)
        text = lines[line - 1] if 0 < line <= len(lines) else ""
        return lsp.Position(max(line - 1, 0), self._units(text[: max(column - 1, 0)]))

    def place(self, path: str, position: lsp.Position) -> tuple[int, int]:
        """An LSP position as a front-end position (1-based line, character column)."""
        lines = self.lines(path)
        text = lines[position.line] if position.line < len(lines) else ""
        column = 0
        while column < len(text) and self._units(text[: column + 1]) <= position.character:
            column += 1
        return position.line + 1, column + 1

    def range(self, span: Span) -> lsp.Range:
        return lsp.Range(self.position(span.file, span.line, span.column),
                         self.position(span.file, span.line, span.column + span.length))

    def location(self, span: Span) -> lsp.Location:
        return lsp.Location(self.uri(span.file), self.range(span))

    # --------------------------------------------------------------------- diagnostics

    def diagnostic(self, d: Diagnostic, main: str) -> lsp.Diagnostic:
        span = d.span or Span(main, 1, 1, 0)
        return lsp.Diagnostic(
            range=self.range(span), message=d.message, severity=_SEVERITIES[d.severity],
            code=d.code, source="asictl",
            related_information=[
                lsp.DiagnosticRelatedInformation(self.location(where), note)
                for where, note in d.related
            ] or None,
        )

    def publish(self) -> None:
        """Check every open program and publish the diagnostics of each file it reads;
        files no longer covered get an empty list."""
        self.pending = None
        now: set[str] = set()
        for analysis in self.documents.analyse_open():
            for file in analysis.files:
                now.add(file)
                items = [self.diagnostic(d, analysis.main) for d in analysis.diagnostics(file)]
                self.text_document_publish_diagnostics(
                    lsp.PublishDiagnosticsParams(uri=self.uri(file), diagnostics=items))
        for file in self.published - now:
            self.text_document_publish_diagnostics(
                lsp.PublishDiagnosticsParams(uri=self.uri(file), diagnostics=[]))
        self.published = now

    def schedule(self, delay: float) -> None:
        if self.pending is not None:
            self.pending.cancel()
        self.pending = asyncio.get_running_loop().call_later(delay, self._publish_or_log)

    def _publish_or_log(self) -> None:
        """``publish`` from a timer: a failure there would otherwise vanish unseen."""
        try:
            self.publish()
        except Exception as exc:  # a bug: tell the editor's log rather than nobody
            self.window_log_message(lsp.LogMessageParams(
                type=lsp.MessageType.Error,
                message=f"asictl {__version__}: internal error while checking: "
                f"{type(exc).__name__}: {exc}"))


def build(lib: Sequence[str] = ()) -> AsiLanguageServer:
    """The server with every feature registered."""
    server = AsiLanguageServer(lib)

    @server.feature(lsp.TEXT_DOCUMENT_DID_OPEN)
    async def did_open(ls: AsiLanguageServer, params: lsp.DidOpenTextDocumentParams) -> None:
        ls.documents.open(ls.path(params.text_document.uri), params.text_document.text)
        ls.schedule(0)

    @server.feature(lsp.TEXT_DOCUMENT_DID_CHANGE)
    async def did_change(ls: AsiLanguageServer, params: lsp.DidChangeTextDocumentParams) -> None:
        document = ls.workspace.get_text_document(params.text_document.uri)
        ls.documents.change(ls.path(params.text_document.uri), document.source)
        ls.schedule(DEBOUNCE_SECONDS)

    @server.feature(lsp.TEXT_DOCUMENT_DID_SAVE)
    async def did_save(ls: AsiLanguageServer, params: lsp.DidSaveTextDocumentParams) -> None:
        ls.schedule(0)  # a block file saved elsewhere may change what a program reads

    @server.feature(lsp.TEXT_DOCUMENT_DID_CLOSE)
    async def did_close(ls: AsiLanguageServer, params: lsp.DidCloseTextDocumentParams) -> None:
        ls.documents.close(ls.path(params.text_document.uri))
        ls.schedule(0)

    @server.feature(lsp.TEXT_DOCUMENT_HOVER)
    def on_hover(ls: AsiLanguageServer, params: lsp.HoverParams) -> lsp.Hover | None:
        path = ls.path(params.text_document.uri)
        line, column = ls.place(path, params.position)
        text = hover.hover(ls.documents.analyse(path), path, line, column)
        if text is None:
            return None
        return lsp.Hover(lsp.MarkupContent(kind=lsp.MarkupKind.Markdown, value=text))

    @server.feature(lsp.TEXT_DOCUMENT_DEFINITION)
    def on_definition(ls: AsiLanguageServer, params: lsp.DefinitionParams
                      ) -> list[lsp.Location]:
        path = ls.path(params.text_document.uri)
        line, column = ls.place(path, params.position)
        spans = navigation.definition(ls.documents.analyse(path), path, line, column)
        return [ls.location(s) for s in spans]

    @server.feature(lsp.TEXT_DOCUMENT_REFERENCES)
    def on_references(ls: AsiLanguageServer, params: lsp.ReferenceParams
                      ) -> list[lsp.Location]:
        path = ls.path(params.text_document.uri)
        line, column = ls.place(path, params.position)
        spans = navigation.references(ls.documents.analyse(path), path, line, column,
                                      declarations=params.context.include_declaration)
        return [ls.location(s) for s in spans]

    @server.feature(
        lsp.TEXT_DOCUMENT_COMPLETION,
        lsp.CompletionOptions(trigger_characters=[" ", "=", "[", "."]),
    )
    def on_completion(ls: AsiLanguageServer, params: lsp.CompletionParams
                      ) -> lsp.CompletionList:
        path = ls.path(params.text_document.uri)
        line, column = ls.place(path, params.position)
        text = ls.documents.text(path)
        items = completion.complete(ls.documents.analyse(path), path, text, line, column)
        return lsp.CompletionList(is_incomplete=False, items=[
            lsp.CompletionItem(
                label=item.label, kind=_COMPLETION_KINDS[item.kind], detail=item.detail or None,
                documentation=lsp.MarkupContent(kind=lsp.MarkupKind.Markdown,
                                                value=item.documentation)
                if item.documentation else None,
                insert_text=item.insert, sort_text=f"{n:04d}",
            )
            for n, item in enumerate(items)
        ])

    @server.feature(lsp.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
    def on_symbols(ls: AsiLanguageServer, params: lsp.DocumentSymbolParams
                   ) -> list[lsp.DocumentSymbol]:
        path = ls.path(params.text_document.uri)
        analysis = ls.documents.analyse(path)
        module = analysis.module(path)
        if module is None:
            return []
        return [_symbol(ls, path, o) for o in navigation.outline(module, analysis.text(path))]

    @server.feature(lsp.TEXT_DOCUMENT_FOLDING_RANGE)
    def on_folding(ls: AsiLanguageServer, params: lsp.FoldingRangeParams
                   ) -> list[lsp.FoldingRange]:
        path = ls.path(params.text_document.uri)
        analysis = ls.documents.analyse(path)
        module = analysis.module(path)
        if module is None:
            return []
        return [lsp.FoldingRange(start_line=first - 1, end_line=last - 1)
                for first, last in navigation.folding_ranges(module, analysis.text(path))]

    @server.feature(lsp.TEXT_DOCUMENT_FORMATTING)
    def on_formatting(ls: AsiLanguageServer, params: lsp.DocumentFormattingParams
                      ) -> list[lsp.TextEdit] | None:
        path = ls.path(params.text_document.uri)
        source = ls.documents.source(path)
        try:
            formatted = format_text(source.text, path).split("\n")
        except DiagnosticError as exc:
            errors = sum(d.is_error for d in exc.diagnostics)
            ls.window_show_message(lsp.ShowMessageParams(
                type=lsp.MessageType.Warning,
                message=f"asictl: not formatted: {errors} syntax error"
                f"{'s' if errors != 1 else ''}"))
            return None
        except FormatError as exc:
            ls.window_show_message(
                lsp.ShowMessageParams(type=lsp.MessageType.Error, message=str(exc)))
            return None
        old = ls.lines(path)
        return [
            lsp.TextEdit(
                lsp.Range(lsp.Position(n, 0), lsp.Position(n, ls._units(old[n]))), new)
            for n, new in enumerate(formatted[: len(old)]) if old[n] != new
        ]

    return server


def _symbol(ls: AsiLanguageServer, path: str, entry: navigation.Outline) -> lsp.DocumentSymbol:
    first, last = entry.lines
    lines = ls.lines(path)
    end = lines[last - 1] if 0 < last <= len(lines) else ""
    return lsp.DocumentSymbol(
        name=entry.name, detail=entry.detail or None, kind=_SYMBOL_KINDS[entry.kind],
        range=lsp.Range(lsp.Position(first - 1, 0), lsp.Position(last - 1, ls._units(end))),
        selection_range=ls.range(entry.selection),
        children=[_symbol(ls, path, child) for child in entry.children] or None,
    )


def serve(lib: Sequence[str] = ()) -> None:
    """Serve one editor on stdin and stdout until it sends exit."""
    build(lib).start_io()
