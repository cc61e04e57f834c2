"""The language server: pygls wiring between the editor and the modules of this package.

Everything the server knows comes from the front end that ``asictl check`` uses
(``documents``), so its diagnostics are exactly the command's. This module only converts:
LSP positions (0-based, counted in the editor's code units, UTF-16 by default) to the
front end's 1-based lines and character columns and back, and results to LSP types.

It also keeps the server answering whatever the client does. The messages are read by
``asictl.lsp.framing`` (a frame without a length or with bad JSON is skipped, and the next
one is read), and a request whose parameters are ill-typed is answered -32602. Checks
run on a worker thread, never on the message loop: while a megabyte program is checked,
hovers on it and other files are answered, and the diagnostics of a version the editor
has already replaced are never published. Positions convert against lines split once
per text, in time proportional to the column, so neither many diagnostics nor a very
long line cost more than linear time.
"""

from __future__ import annotations

import asyncio
import logging
import sys
import threading
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, BinaryIO

import cattrs
from lsprotocol import types as lsp
from pygls import uris
from pygls.exceptions import JsonRpcException, JsonRpcInvalidParams, JsonRpcInvalidRequest
from pygls.io_ import StdoutWriter
from pygls.lsp.server import LanguageServer

from asictl import __version__
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity, Span
from asictl.il.format import FormatError, format_text
from asictl.lsp import completion, hover, navigation
from asictl.lsp.documents import Analysis, Documents, normal
from asictl.lsp.framing import Malformed, Reader
from asictl.source import MAX_SOURCE_BYTES

#: How long the server waits after the last change before it checks again.
DEBOUNCE_SECONDS = 0.3
#: The largest message read: a whole source file, each character escaped in JSON
#: (``\u0000``, 6 bytes), and room for the rest of the message.
MAX_MESSAGE = 6 * MAX_SOURCE_BYTES + (1 << 16)

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
        #: main program -> the analysis whose diagnostics the editor was sent
        self.published: dict[str, Analysis] = {}
        #: file -> the main program whose analysis last published its diagnostics
        self.shown: dict[str, str] = {}
        self.pending: asyncio.TimerHandle | None = None
        self.checking: asyncio.Future[None] | None = None
        #: a change arrived while a check ran: check again when it ends
        self.again = False
        #: checks for diagnostics, one at a time, off the message loop
        self.checker = ThreadPoolExecutor(1, "asictl-check")
        #: the analyses a request needs that no check has made yet
        self.answerer = ThreadPoolExecutor(1, "asictl-answer")

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
        return self.documents.lines(path)

    def _units(self, text: str) -> int:
        return _units(text, self.workspace.position_encoding)

    def _column(self, text: str, units: int) -> int:
        """How many characters of ``text`` its first ``units`` code units hold whole.

        Every character takes at least one unit, so they lie within the first ``units``
        characters: the time is the column's, not the line's, and one encoding of them
        settles the usual case (a hover at the end of a line of 400,000 characters took
        46 s when every prefix was encoded in turn)."""
        encoding = self.workspace.position_encoding
        prefix = text[:units]
        if _units(prefix, encoding) == len(prefix):  # one unit each (ASCII, or UTF-32)
            return len(prefix)
        count = 0
        for n, char in enumerate(prefix):
            count += _units(char, encoding)
            if count > units:
                return n
        return len(prefix)

    def position(self, lines: list[str], line: int, column: int) -> lsp.Position:
        """A front-end position (1-based, characters) in ``lines`` as an LSP position."""
        text = lines[line - 1] if 0 < line <= len(lines) else ""
        return lsp.Position(max(line - 1, 0), self._units(text[: max(column - 1, 0)]))

    def place(self, lines: list[str], position: lsp.Position) -> tuple[int, int]:
        """An LSP position as a front-end position (1-based line, character column)."""
        text = lines[position.line] if position.line < len(lines) else ""
        return position.line + 1, self._column(text, position.character) + 1

    def range(self, lines: list[str], span: Span) -> lsp.Range:
        return lsp.Range(self.position(lines, span.line, span.column),
                         self.position(lines, span.line, span.column + span.length))

    def location(self, analysis: Analysis, span: Span) -> lsp.Location:
        return lsp.Location(self.uri(span.file), self.range(analysis.lines(span.file), span))

    # ------------------------------------------------------------------------ requests

    async def analysis(self, path: str) -> Analysis:
        """The analysis a request reads: the one kept, else one made on the answering
        thread, so that the message loop goes on meanwhile."""
        found = self.documents.cached(path)
        if found is not None:
            return found
        loop = asyncio.get_running_loop()
        return await loop.run_in_executor(self.answerer, self.documents.analyse, path)

    async def at(self, params: _AtPosition) -> tuple[Analysis, str, int, int]:
        """The analysis, file and front-end position of a request at a position."""
        path = self.path(params.text_document.uri)
        analysis = await self.analysis(path)
        lines = analysis.lines(path) if path in analysis.files else self.lines(path)
        line, column = self.place(lines, params.position)
        return analysis, path, line, column

    # --------------------------------------------------------------------- diagnostics

    def diagnostic(self, d: Diagnostic, analysis: Analysis) -> lsp.Diagnostic:
        span = d.span or Span(analysis.main, 1, 1, 0)
        return lsp.Diagnostic(
            range=self.range(analysis.lines(span.file), span), message=d.message,
            severity=_SEVERITIES[d.severity], code=d.code, source="asictl",
            related_information=[
                lsp.DiagnosticRelatedInformation(self.location(analysis, where), note)
                for where, note in d.related
            ] or None,
        )

    def schedule(self, delay: float) -> None:
        if self.pending is not None:
            self.pending.cancel()
        self.pending = asyncio.get_running_loop().call_later(delay, self.check)

    def check(self) -> None:
        """Start checking the open programs, or, while a check runs, have it run again
        when it ends (with the texts of then)."""
        self.pending = None
        if self.checking is not None:
            self.again = True
            return
        self.checking = asyncio.ensure_future(self._check_and_publish())

    async def _check_and_publish(self) -> None:
        try:
            loop = asyncio.get_running_loop()
            mains, found = await loop.run_in_executor(self.checker, self._diagnostics)
            self._publish(mains, found)
        except Exception as exc:  # a bug: tell the editor's log rather than nobody
            self.window_log_message(lsp.LogMessageParams(
                type=lsp.MessageType.Error,
                message=f"asictl {__version__}: internal error while checking: "
                f"{type(exc).__name__}: {exc}"))
        finally:
            self.checking = None
            if self.again:
                self.again = False
                self.check()

    def _diagnostics(self) -> tuple[list[str], list[tuple[Analysis, _ByFile]]]:
        """On the checker's thread: the main programs of the open files, and the analyses
        among theirs that the editor has not seen, with their diagnostics by file. An
        analysis a later change has made stale is left out: that change asked for another
        check."""
        mains: list[str] = []
        found: list[tuple[Analysis, _ByFile]] = []
        for analysis in self.documents.analyse_open():
            mains.append(analysis.main)
            if self.published.get(analysis.main) is not analysis:
                by_file = self._convert(analysis)
                if by_file is not None:
                    found.append((analysis, by_file))
        return mains, found

    def _convert(self, analysis: Analysis) -> _ByFile | None:
        """The analysis's diagnostics as the editor gets them, or None as soon as a change
        makes it stale (tens of thousands of them take a while)."""
        by_file: _ByFile = {}
        for file in analysis.files:
            items = by_file[file] = []
            for n, d in enumerate(analysis.diagnostics(file)):
                if n % 1000 == 0 and not self.documents.is_current(analysis):
                    return None
                items.append(self.diagnostic(d, analysis))
        return by_file if self.documents.is_current(analysis) else None

    def _publish(self, mains: list[str], found: list[tuple[Analysis, _ByFile]]) -> None:
        """Send what a check found that is still current; files no longer covered by
        any program get an empty list."""
        for analysis, by_file in found:
            if not self.documents.is_current(analysis):
                continue  # changed while its diagnostics were made: checked again soon
            self.published[analysis.main] = analysis
            for file, items in by_file.items():
                self.shown[file] = analysis.main
                self.text_document_publish_diagnostics(
                    lsp.PublishDiagnosticsParams(uri=self.uri(file), diagnostics=items))
        for main in set(self.published) - set(mains):
            del self.published[main]
        for file, main in list(self.shown.items()):
            if main in self.published and file in self.published[main].files:
                continue
            del self.shown[file]
            if not any(file in a.files for a in self.published.values()):
                self.text_document_publish_diagnostics(
                    lsp.PublishDiagnosticsParams(uri=self.uri(file), diagnostics=[]))

    # ------------------------------------------------------------------- the messages

    def run(self, stdin: BinaryIO, stdout: BinaryIO) -> None:
        """Serve the client on ``stdin`` and ``stdout`` until it sends exit (which ends
        the process) or its input ends."""
        self._stop_event = threading.Event()
        self.protocol.set_writer(StdoutWriter(stdout))
        # pygls logs a traceback to standard error for every message it cannot read; the
        # server answers or logs those itself, in one line, and a client that does not
        # drain standard error would otherwise stall the server once the pipe is full.
        logging.getLogger("pygls").setLevel(logging.CRITICAL)
        try:
            asyncio.run(self._serve(stdin))
        finally:
            self.checker.shutdown(wait=False, cancel_futures=True)
            self.answerer.shutdown(wait=False, cancel_futures=True)

    async def _serve(self, stdin: BinaryIO) -> None:
        """Read frames on a thread of their own (a read blocks) and handle each message
        on the loop. Malformed frames are logged and skipped."""
        loop = asyncio.get_running_loop()
        inbox: asyncio.Queue[dict[str, Any] | Malformed | None] = asyncio.Queue()
        reader = Reader(stdin, max_body=MAX_MESSAGE)

        def read() -> None:
            while True:
                message = reader.read()
                try:
                    loop.call_soon_threadsafe(inbox.put_nowait, message)
                except RuntimeError:  # the loop has ended (exit)
                    return
                if message is None:
                    return

        threading.Thread(target=read, name="asictl-lsp-input", daemon=True).start()
        while (message := await inbox.get()) is not None:
            if isinstance(message, Malformed):
                self._log(lsp.MessageType.Warning, f"a message was skipped: {message.why}")
            else:
                self.receive(message)

    def receive(self, message: dict[str, Any]) -> None:
        """Hand one message to pygls, answering what it would leave unanswered: a request
        that is no JSON-RPC 2.0 request (-32600) or whose parameters do not have the
        protocol's types (-32602)."""
        ident = message.get("id")
        is_request = "method" in message and "id" in message
        if message.get("jsonrpc") != "2.0" or not isinstance(message.get("method", ""), str) \
                or ("id" in message and not isinstance(ident, int | str)):
            self._refuse(message, JsonRpcInvalidRequest(
                "Invalid Request: not a JSON-RPC 2.0 message"), is_request)
            return
        try:
            structured = self.protocol.structure_message(message)
        except JsonRpcInvalidParams as exc:
            self._refuse(message, JsonRpcInvalidParams(
                f"Invalid Params: {_why(exc)}"), is_request)
            return
        except JsonRpcException as exc:
            self._refuse(message, JsonRpcInvalidRequest(
                f"Invalid Request: {_why(exc)}"), is_request)
            return
        try:
            self.protocol.handle_message(structured)
        except Exception as exc:  # a bug in handling one message must not end the server
            self._log(lsp.MessageType.Error, f"internal error: {type(exc).__name__}: {exc}")

    def _refuse(self, message: dict[str, Any], error: JsonRpcException,
                is_request: bool) -> None:
        method = str(message.get("method", "a message"))[:80]
        if is_request:
            ident = message.get("id")
            self.protocol._send_data(lsp.ResponseErrorMessage(
                id=ident if isinstance(ident, int | str) else None,
                error=error.to_response_error()))
        else:
            self._log(lsp.MessageType.Warning, f"{method} ignored: {error}")

    def _log(self, kind: lsp.MessageType, text: str) -> None:
        self.window_log_message(lsp.LogMessageParams(type=kind, message=f"asictl: {text}"))


#: file -> its diagnostics as the editor gets them
_ByFile = dict[str, list[lsp.Diagnostic]]
#: the requests made at a position in a file
_AtPosition = lsp.HoverParams | lsp.DefinitionParams | lsp.ReferenceParams | lsp.CompletionParams


def _units(text: str, encoding: lsp.PositionEncodingKind | str | None) -> int:
    """The length of ``text`` in the editor's code units (UTF-16 unless it chose)."""
    if encoding == lsp.PositionEncodingKind.Utf8:
        return len(text.encode("utf-8"))
    if encoding == lsp.PositionEncodingKind.Utf32:
        return len(text)
    return len(text.encode("utf-16-le")) // 2


def _why(exc: JsonRpcException) -> str:
    """What was wrong with a message, in cattrs's words where it has them (``invalid
    value for type, expected int @ $.params.position.line``)."""
    cause = exc.__cause__
    if isinstance(cause, cattrs.ClassValidationError):
        return "; ".join(cattrs.transform_error(cause))[:500]
    return f"{type(cause).__name__}: {cause}"[:500] if cause else str(exc)


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
        ls.documents.reload()  # a block file saved elsewhere may change what a program reads
        ls.schedule(0)

    @server.feature(lsp.TEXT_DOCUMENT_DID_CLOSE)
    async def did_close(ls: AsiLanguageServer, params: lsp.DidCloseTextDocumentParams) -> None:
        ls.documents.close(ls.path(params.text_document.uri))
        ls.schedule(0)

    @server.feature(lsp.TEXT_DOCUMENT_HOVER)
    async def on_hover(ls: AsiLanguageServer, params: lsp.HoverParams) -> lsp.Hover | None:
        analysis, path, line, column = await ls.at(params)
        text = hover.hover(analysis, path, line, column)
        if text is None:
            return None
        return lsp.Hover(lsp.MarkupContent(kind=lsp.MarkupKind.Markdown, value=text))

    @server.feature(lsp.TEXT_DOCUMENT_DEFINITION)
    async def on_definition(ls: AsiLanguageServer, params: lsp.DefinitionParams
                            ) -> list[lsp.Location]:
        analysis, path, line, column = await ls.at(params)
        spans = navigation.definition(analysis, path, line, column)
        return [ls.location(analysis, s) for s in spans]

    @server.feature(lsp.TEXT_DOCUMENT_REFERENCES)
    async def on_references(ls: AsiLanguageServer, params: lsp.ReferenceParams
                            ) -> list[lsp.Location]:
        analysis, path, line, column = await ls.at(params)
        spans = navigation.references(analysis, path, line, column,
                                      declarations=params.context.include_declaration)
        return [ls.location(analysis, s) for s in spans]

    @server.feature(
        lsp.TEXT_DOCUMENT_COMPLETION,
        lsp.CompletionOptions(trigger_characters=[" ", "=", "[", "."]),
    )
    async def on_completion(ls: AsiLanguageServer, params: lsp.CompletionParams
                            ) -> lsp.CompletionList:
        analysis, path, line, column = await ls.at(params)
        items = completion.complete(analysis, path, ls.lines(path), line, column)
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
    async def on_symbols(ls: AsiLanguageServer, params: lsp.DocumentSymbolParams
                         ) -> list[lsp.DocumentSymbol]:
        path = ls.path(params.text_document.uri)
        analysis = await ls.analysis(path)
        module = analysis.module(path)
        if module is None:
            return []
        return [_symbol(ls, analysis, path, o)
                for o in navigation.outline(module, analysis.text(path))]

    @server.feature(lsp.TEXT_DOCUMENT_FOLDING_RANGE)
    async def on_folding(ls: AsiLanguageServer, params: lsp.FoldingRangeParams
                         ) -> list[lsp.FoldingRange]:
        path = ls.path(params.text_document.uri)
        analysis = await ls.analysis(path)
        module = analysis.module(path)
        if module is None:
            return []
        return [lsp.FoldingRange(start_line=first - 1, end_line=last - 1)
                for first, last in navigation.folding_ranges(module, analysis.text(path))]

    @server.feature(lsp.TEXT_DOCUMENT_FORMATTING)
    async def on_formatting(ls: AsiLanguageServer, params: lsp.DocumentFormattingParams
                            ) -> list[lsp.TextEdit] | None:
        path = ls.path(params.text_document.uri)
        text = ls.documents.text(path)
        loop = asyncio.get_running_loop()
        try:  # on the answering thread: a megabyte takes a while
            formatted = (await loop.run_in_executor(ls.answerer, format_text, text, path)
                         ).split("\n")
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
        old = text.split("\n")
        return [
            lsp.TextEdit(
                lsp.Range(lsp.Position(n, 0), lsp.Position(n, ls._units(old[n]))), new)
            for n, new in enumerate(formatted[: len(old)]) if old[n] != new
        ]

    return server


def _symbol(ls: AsiLanguageServer, analysis: Analysis, path: str, entry: navigation.Outline
            ) -> lsp.DocumentSymbol:
    first, last = entry.lines
    lines = analysis.lines(path)
    end = lines[last - 1] if 0 < last <= len(lines) else ""
    return lsp.DocumentSymbol(
        name=entry.name, detail=entry.detail or None, kind=_SYMBOL_KINDS[entry.kind],
        range=lsp.Range(lsp.Position(first - 1, 0), lsp.Position(last - 1, ls._units(end))),
        selection_range=ls.range(lines, entry.selection),
        children=[_symbol(ls, analysis, path, child) for child in entry.children] or None,
    )


def serve(lib: Sequence[str] = ()) -> None:
    """Serve one editor on stdin and stdout until it sends exit.

    The input is read through a file object of its own, never closed: the reading thread
    may be waiting inside it when the process ends, and Python aborts an exit that finds
    ``sys.stdin``'s buffer locked by such a thread (closing it would wait for ever)."""
    stdin = open(sys.stdin.fileno(), "rb", closefd=False)  # noqa: SIM115 - see above
    build(lib).run(stdin, sys.stdout.buffer)
