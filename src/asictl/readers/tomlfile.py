"""TOML files read one way: tomllib for the values, this module for the places.

Every TOML file asictl reads (scenarios, symbol tables, properties, inventories, watch
tables) reports a mistake as ``FILE:LINE:COL: error: MESSAGE [Ennn]`` with the source
line and a caret at the key or value. tomllib gives values but no positions, and its
errors carry the position only in their text; tomlkit would keep positions but is one
more dependency for a task this small. So the text is read twice: tomllib decides what
is valid TOML and what the values are, and ``_Walker`` then walks the same (now known to
be valid) text once to note where each key and each value starts.

A place is named by its *path*, as the data is reached: ``("step", 2, "set", "I 1.0")``
is the key ``"I 1.0"`` in the ``set`` table of the third ``[[step]]``. ``Document.key``
and ``Document.value`` give a ``Span`` for any path, falling back to the nearest
enclosing place that has one, so a message never lacks a line.

A syntax error reads the same in every file kind (code E400, "not valid TOML: ...", at
tomllib's line and column); so does nesting beyond ``MAX_NESTING`` (tomllib would
recurse until Python's stack runs out) and an unknown key, with its did-you-mean.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

from asictl.codes import ScenarioCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity, Span
from asictl.readers.strings import string_column
from asictl.readers.suggest import did_you_mean

#: A place in the data: table keys and array indexes from the top.
KeyPath = tuple[str | int, ...]

#: Line, column (both from 1) and length of a key or value in the text.
Place = tuple[int, int, int]

#: Arrays and inline tables nested deeper than this are refused (no file needs 4).
MAX_NESTING = 32


@dataclass
class Document:
    """A TOML file's values (``data``) and the place of every key and value in its text."""

    name: str
    text: str
    data: dict[str, object]
    #: line, column and length of each key as written (of its name, for a header's table)
    keys: dict[KeyPath, Place] = field(default_factory=dict)
    #: line, column (and 1) where each value starts (the ``[`` of a header's table)
    values: dict[KeyPath, Place] = field(default_factory=dict)

    def key(self, path: KeyPath) -> Span:
        """Where the key of ``path`` is written (a header's table: its name in the header,
        an element of ``[[name]]``: its header); else its value, else the nearest
        enclosing place."""
        return self._span(path, self.keys, self.values)

    def value(self, path: KeyPath) -> Span:
        """Where the value of ``path`` starts (a string's opening quote); else its key,
        else the nearest enclosing place."""
        return self._span(path, self.values, self.keys)

    def inside(self, path: KeyPath, offset: int = 0, length: int = 1) -> Span:
        """Where character ``offset`` of the string at ``path`` stands, past its opening
        quote(s) and through its escapes (``readers.strings``), covering ``length``
        characters: a mistake inside a string is shown at its own place."""
        span = self.value(path)
        lines = self.text.split("\n")
        line = lines[span.line - 1] if 0 < span.line <= len(lines) else ""
        if line[span.column - 1 : span.column] not in ('"', "'"):
            return span
        return Span(self.name, span.line, string_column(line, span.column - 1, offset),
                    max(length, 1))

    def _span(self, path: KeyPath, first: Mapping[KeyPath, Place],
              then: Mapping[KeyPath, Place]) -> Span:
        while path:
            found = first.get(path) or then.get(path)
            if found:
                return Span(self.name, *found)
            path = path[:-1]
        return Span(self.name, 1, 1)

    def error(self, code: str, message: str, path: KeyPath, *, at_value: bool = False
              ) -> Diagnostic:
        """An error at ``path``'s key (or value)."""
        span = self.value(path) if at_value else self.key(path)
        return Diagnostic(Severity.ERROR, code, message, span)

    def unknown_keys(self, path: KeyPath, table: Mapping[str, object], known: Iterable[str],
                     where: str = "") -> list[Diagnostic]:
        """One error per key of ``table`` (at ``path``) that is not ``known``, at the key,
        with the closest known name: ``unknown key 'cycle_m' in [master]; did you mean
        'cycle_ms'? (known: cycle_ms, slaves)``."""
        names = sorted(known)
        place = f" {where}" if where else ""
        return [
            self.error(ScenarioCode.UNKNOWN_KEY,
                       f"unknown key '{name}'{place}{did_you_mean(name, names)} "
                       f"(known: {', '.join(names)})", (*path, name))
            for name in sorted(set(table) - set(names))
        ]


def read_toml(name: str, text: str) -> Document:
    """The document in ``text`` (from the file ``name``); ``DiagnosticError`` (E400) at
    the place where it is not TOML."""
    deep = _too_deep(text)
    if deep:
        raise _not_toml(name, f"arrays or tables nested more than {MAX_NESTING} deep", deep)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message, place = _decode_error(str(exc), text)
        raise _not_toml(name, message, place) from None
    except ValueError as exc:  # a number Python will not convert (thousands of digits)
        raise _not_toml(name, str(exc), (1, 1)) from None
    document = Document(name, text, data)
    _Walker(text, document).walk()
    return document


def _not_toml(name: str, message: str, place: tuple[int, ...]) -> DiagnosticError:
    return DiagnosticError([Diagnostic(Severity.ERROR, ScenarioCode.NOT_TOML,
                                       f"not valid TOML: {message}", Span(name, *place))])


_AT = re.compile(r"\s*\(at (?:line (\d+), column (\d+)|end of document)\)\s*$")


def _decode_error(text: str, source: str) -> tuple[str, tuple[int, int]]:
    """tomllib's message without its position, its first letter lower case, and the
    position (``at end of document``: after the last character)."""
    found = _AT.search(text)
    message = text[: found.start()] if found else text
    message = message[:1].lower() + message[1:]
    if found and found[1]:
        return message, (int(found[1]), int(found[2]))
    lines = source.split("\n")
    return message, (len(lines), len(lines[-1]) + 1)


def _too_deep(text: str) -> Place | None:
    """Where brackets first nest deeper than ``MAX_NESTING`` (strings and comments
    skipped), in any text, valid TOML or not."""
    depth = 0
    scanner = _Scanner(text)
    while scanner.i < len(text):
        c = text[scanner.i]
        if c == "#":
            scanner.skip_comment()
        elif c in "\"'":
            scanner.string()
        elif c in "[{":
            depth += 1
            if depth > MAX_NESTING:
                return scanner.place()
            scanner.i += 1
        elif c in "]}":
            depth = max(0, depth - 1)
            scanner.i += 1
        else:
            scanner.i += 1
    return None


class _Scanner:
    """A position in a TOML text and the lexical pieces every walk needs."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.i = 0
        self.line_starts = [0] + [m.end() for m in re.finditer("\n", text)]

    def place(self, at: int | None = None, length: int = 1) -> Place:
        """1-based line and column of offset ``at`` (default: here)."""
        offset = self.i if at is None else at
        lo, hi = 0, len(self.line_starts) - 1
        while lo < hi:  # the last line start at or before offset
            mid = (lo + hi + 1) // 2
            if self.line_starts[mid] <= offset:
                lo = mid
            else:
                hi = mid - 1
        return lo + 1, offset - self.line_starts[lo] + 1, length

    def peek(self) -> str:
        return self.text[self.i] if self.i < len(self.text) else ""

    def skip_comment(self) -> None:
        end = self.text.find("\n", self.i)
        self.i = len(self.text) if end < 0 else end

    def skip_blank(self, *, newlines: bool) -> None:
        """Past spaces and tabs (and newlines and comments, where ``newlines``)."""
        while self.i < len(self.text):
            c = self.text[self.i]
            if c in " \t" or (newlines and c in "\r\n"):
                self.i += 1
            elif newlines and c == "#":
                self.skip_comment()
            else:
                return

    def string(self) -> str:
        """Past the string here (basic, literal, multi-line); its text as a key reads
        it (escapes of basic one-line strings resolved, which is all a key may be)."""
        text, i = self.text, self.i
        quote = text[i]
        if text.startswith(quote * 3, i):
            end = i + 3
            while True:
                end = text.find(quote * 3, end)
                if end < 0 or quote == "'" or not _escaped(text, end):
                    break
                end += 1
            stop = len(text) if end < 0 else end + 3
            while stop < len(text) and text[stop] == quote:  # """a"""" ends at the last
                stop += 1
            self.i = stop
            return text[i + 3 : stop - 3]
        j = i + 1
        while j < len(text) and text[j] not in (quote, "\n"):
            j += 2 if quote == '"' and text[j] == "\\" else 1
        self.i = min(j + 1, len(text))
        raw = text[i + 1 : j]
        if quote == "'" or "\\" not in raw:
            return raw
        try:
            return str(tomllib.loads(f"k = {text[i : j + 1]}")["k"])
        except tomllib.TOMLDecodeError:  # an invalid escape (placing the error it is)
            return raw


def _escaped(text: str, at: int) -> bool:
    backslashes = 0
    while at - backslashes - 1 >= 0 and text[at - backslashes - 1] == "\\":
        backslashes += 1
    return backslashes % 2 == 1


_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


class _Walker(_Scanner):
    """One walk over a valid TOML text, noting each key's and value's place in a
    ``Document`` (the first place a path is written, where dotted keys and headers
    write a table's path more than once)."""

    def __init__(self, text: str, document: Document) -> None:
        super().__init__(text)
        self.document = document
        #: the number of ``[[name]]`` tables seen so far, by the array's path
        self.counts: dict[KeyPath, int] = {}

    def walk(self) -> None:
        table: KeyPath = ()
        while True:
            self.skip_blank(newlines=True)
            if self.i >= len(self.text):
                return
            if self.text.startswith("[[", self.i):
                table = self.header(array=True)
            elif self.peek() == "[":
                table = self.header(array=False)
            else:
                self.key_value(table)

    def resolve(self, names: list[tuple[str, Place]]) -> KeyPath:
        """The path of dotted header names: into the last table of each array of tables."""
        path: KeyPath = ()
        for name, place in names:
            path = (*path, name)
            self.document.keys.setdefault(path, place)
            if path in self.counts:
                path = (*path, self.counts[path])
        return path

    def header(self, *, array: bool) -> KeyPath:
        start = self.place()
        self.i += 2 if array else 1
        names = self.dotted_key()
        if not array:
            path = self.resolve(names)
        else:
            parent = self.resolve(names[:-1])
            name, place = names[-1]
            aot = (*parent, name)
            self.document.keys.setdefault(aot, place)
            self.counts[aot] = self.counts.get(aot, -1) + 1
            path = (*aot, self.counts[aot])
        self.document.keys.setdefault(path, start)
        self.document.values.setdefault(path, start)
        self.i = self.text.index("]]" if array else "]", self.i) + (2 if array else 1)
        return path

    def dotted_key(self) -> list[tuple[str, Place]]:
        """``a."b c".d``: each part with its place; stops before ``=`` or ``]``."""
        parts = []
        while True:
            self.skip_blank(newlines=False)
            start = self.i
            if self.peek() in "\"'":
                name = self.string()
            else:
                found = _BARE_KEY.match(self.text, self.i)
                assert found, "tomllib accepted the text: a key starts here"
                name, self.i = found[0], found.end()
            parts.append((name, self.place(start, self.i - start)))
            self.skip_blank(newlines=False)
            if self.peek() != ".":
                return parts
            self.i += 1

    def key_value(self, table: KeyPath) -> None:
        names = self.dotted_key()
        path = table
        for name, place in names:
            path = (*path, name)
            self.document.keys.setdefault(path, place)
        self.i += 1  # =
        self.skip_blank(newlines=False)
        self.value(path)

    def value(self, path: KeyPath) -> None:
        self.document.values.setdefault(path, self.place())
        c = self.peek()
        if c in "\"'":
            self.string()
        elif c == "[":
            self.array(path)
        elif c == "{":
            self.inline_table(path)
        else:  # a number, date, time, boolean: up to what ends a value
            found = re.compile(r"[^,\]}#\n]*").match(self.text, self.i)
            assert found is not None
            self.i = found.end()

    def array(self, path: KeyPath) -> None:
        self.items("]", lambda index: self.value((*path, index)))

    def inline_table(self, path: KeyPath) -> None:
        self.items("}", lambda _: self.key_value(path))

    def items(self, close: str, item: Callable[[int], None]) -> None:
        """The items of an array or inline table, up to ``close``: ``item(index)`` reads
        each (comments and newlines between them skipped)."""
        self.i += 1
        index = 0
        while True:
            self.skip_blank(newlines=True)
            if self.peek() == close:
                self.i += 1
                return
            if self.peek() == ",":
                self.i += 1
                continue
            item(index)
            index += 1


def toml_string(text: str) -> str:
    """``text`` as a TOML basic string, quotes and control characters escaped."""
    escaped = []
    for c in text:
        if c in '"\\':
            escaped.append("\\" + c)
        elif c == "\n":
            escaped.append("\\n")
        elif c == "\t":
            escaped.append("\\t")
        elif ord(c) < 0x20 or ord(c) == 0x7F:
            escaped.append(f"\\u{ord(c):04x}")
        else:
            escaped.append(c)
    return '"' + "".join(escaped) + '"'


def toml_key(name: str) -> str:
    """``name`` as a TOML key: bare where it can be, else quoted."""
    return name if _BARE_KEY.fullmatch(name) else toml_string(name)
