"""The canonical layout of IL source: what ``asictl fmt`` and an editor's "format" write.

The layout follows the demo programs: a label column, the operator in a field of four
after it, the operand, and comments aligned in a column per section. Only the layout
changes, never the meaning, the words or the line structure:

- every line stays a line: blank lines, comment lines and comments stay where they are;
- words keep their spelling (``a i 4.0`` stays lower case, ``0Ah`` stays hexadecimal);
- blanks, and the punctuation the language reads as a blank (``16 iiio, 1, Eh``), become
  single blanks, or the column padding; ``[ASSEMBLY]`` and ``[RAW]`` lines, ``ASM`` text,
  file names and everything from ``[END]`` on are kept as written.

A file with syntax errors is not formatted (``DiagnosticError``): what a line means is
only known when it parses. The result is parsed again and must give the same AST; if it
did not, that would be a bug here, and it is raised rather than written.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import assert_never

from asictl.diagnostics import DiagnosticError
from asictl.il import ast
from asictl.il.parser import parse
from asictl.source import SourceText, from_string, text_form

#: Where instructions start when no label is longer: the demos' eight columns.
INSTRUCTION_COLUMN = 8
#: The operator field: "A   I 1.0", "JU  FB Latch".
OPERATOR_WIDTH = 4
#: Comments start at this column (0-based) at least, and further right when the code of
#: the section is wider, but never beyond COMMENT_LIMIT: longer lines put two blanks.
COMMENT_COLUMN = 28
COMMENT_LIMIT = 56

#: Blanks and the punctuation the language reads as a blank (docs/language.md).
_BLANKS = re.compile(r"[\s\"#$%&',/?@\\^`{|}~]+")
_RECORD = re.compile(r"\s*:")


class FormatError(AssertionError):
    """The formatter would have changed a program's meaning: a bug in the formatter."""


@dataclass
class _Line:
    """One source line while it is laid out: its code (without comment) and comment."""

    code: str
    comment: str
    section: ast.Section | None
    nodes: list[ast.BodyNode] = field(default_factory=list)
    is_title: bool = False


def format_text(text: str, name: str = "<string>") -> str:
    """``text`` (LF line ends) in the canonical layout; syntax errors raise
    ``DiagnosticError``."""
    return _format(from_string(name, text))


def format_source(source: SourceText) -> bytes:
    """A file's bytes in the canonical layout, in the file's own encoding, line ends,
    byte order mark and DOS end-of-file mark."""
    return text_form(source.raw).encode(_format(source))


def _format(source: SourceText) -> str:
    module, diagnostics = parse(source)
    if diagnostics:
        raise DiagnosticError(diagnostics)
    lines = source.text.split("\n")
    end = _end_line(lines, module)
    head = [_split(line) for line in lines[:end]]
    _attach(head, module)
    widths = _key_widths(head)
    laid = [_lay_out(line, widths) if line.code.strip() else "" for line in head]
    comment_columns = _comment_columns(head, laid)
    out = [
        _with_comment(code, line.comment, comment_columns.get(id(line.section), COMMENT_COLUMN))
        if code and not _verbatim(line) else original.rstrip()
        for line, code, original in zip(head, laid, lines, strict=False)
    ]
    result = "\n".join(out + lines[end:])
    _verify(module, source.name, result)
    return result


def _verbatim(line: _Line) -> bool:
    """[ASSEMBLY] lines stay as written, less trailing blanks (as blank and comment lines
    do everywhere): their layout is the assembler's business."""
    return isinstance(line.section, ast.AssemblySection) and not line.is_title


def _verify(module: ast.Module, name: str, text: str) -> None:
    again, diagnostics = parse(from_string(name, text))
    if diagnostics or again != module:
        raise FormatError(f"{name}: formatting would change the program; the file is left as is")


# ----------------------------------------------------------------- reading the lines


def _split(line: str) -> _Line:
    code, semicolon, comment = line.partition(";")
    return _Line(code, (semicolon + comment).rstrip(), None)


def _attach(lines: list[_Line], module: ast.Module) -> None:
    """Give each line its section and the AST nodes that start on it."""
    for section in module.sections:
        if section.span is None:
            continue
        title = section.span.line - 1
        lines[title].is_title = True
        following = [s.span.line - 1 for s in module.sections if s.span and s.span.line > title + 1]
        stop = min(following, default=len(lines))
        for line in lines[title:stop]:
            line.section = section
        for node in ast.nodes(section):
            span = node.span
            if span is not None and span.line - 1 < len(lines):
                lines[span.line - 1].nodes.append(node)


def _end_line(lines: list[str], module: ast.Module) -> int:
    """The index of the [END] line (everything from it on is kept), or len(lines).

    The file parsed, so after the last node a line that is neither blank, a comment, a
    title nor a [RAW] record can only be the end.
    """
    last = 0
    taken: set[int] = set()
    for section in module.sections:
        if section.span is not None:
            taken.add(section.span.line)
            last = max(last, section.span.line)
        for node in ast.nodes(section):
            span = node.span
            if span is not None:
                taken.add(span.line)
                last = max(last, span.line)
    raw = bool(module.sections) and isinstance(module.sections[-1], ast.RawSection)
    for index in range(last, len(lines)):
        code = lines[index].partition(";")[0]
        if index + 1 in taken or not code.strip() or (raw and _RECORD.match(code)):
            continue
        return index
    return len(lines)


# -------------------------------------------------------------------- laying out


def _words(text: str) -> str:
    """The words of ``text``, one blank apart."""
    return " ".join(w for w in _BLANKS.split(text) if w)


def _lay_out(line: _Line, widths: dict[int, int]) -> str:
    """The code of one line in the canonical layout (no comment yet)."""
    section = line.section
    if line.is_title or section is None:
        return line.code.strip()
    width = widths.get(id(section), 0)
    match section:
        case ast.OptionsSection():
            return _keyed(line.code, 2, width)
        case ast.SetupSection():
            return _keyed(line.code, 4, width)
        case ast.DeclSection():
            return _declarations(line, width)
        case ast.ProgramSection():
            return _statement(line)
        case ast.GatingSection():
            return re.sub(r"\s*=\s*", " = ", _words(line.code))
        case ast.RawSection() | ast.AssemblySection():
            return line.code.strip()  # records; [ASSEMBLY] lines are kept (see _verbatim)
        case _:
            assert_never(section)


def _key_widths(lines: list[_Line]) -> dict[int, int]:
    """Per [OPTIONS], [SETUP] and [DECL] section (by id): the width of its first column,
    "name:", "address:" (one blank after) or the declared name (two blanks after)."""
    widths: dict[int, int] = {}
    for line in lines:
        section = line.section
        if line.is_title or not line.nodes:
            continue
        if isinstance(section, ast.OptionsSection | ast.SetupSection):
            key = _KEYED.split(line.code.strip())[0] + ":"
        elif isinstance(section, ast.DeclSection) and len(line.nodes) == 1:
            key = _declaration_parts(line, line.nodes[0])[0] + " "
        else:
            continue
        widths[id(section)] = max(widths.get(id(section), 0), len(key) + 1)
    return widths


#: The separators of [OPTIONS] and [SETUP] lines: blanks, ':' and blank-like punctuation.
_KEYED = re.compile(r"[\s:\"#$%&',/?@\\^`{|}~]+")


def _keyed(code: str, most: int, width: int) -> str:
    """"auto_start: yes", "16: iiio, 1, Eh": the first word and ':' in a column of
    ``width``, the others (at most ``most`` words in all) after it."""
    words = [w for w in _KEYED.split(code) if w]
    if not 2 <= len(words) <= most:
        return _words(code)
    return f"{words[0]}:".ljust(width) + ", ".join(words[1:])


def _declaration_parts(line: _Line, decl: ast.BodyNode) -> tuple[str, str]:
    """A declaration as (name, rest): ("Reading", "BYTE 5"), ("T134", "TIMER")."""
    assert isinstance(decl, ast.Declaration) and decl.span is not None  # a [DECL] line's
    span = decl.span
    text = line.code[span.column - 1 : span.column - 1 + span.length]
    match decl:
        case ast.FBDecl(name=name, file=file):
            # the file name is kept as written: it may hold any punctuation
            return name, f"{_words(text[len(name):len(text) - len(file)])} {file}"
        case ast.VarDecl(name=name):
            return name, _words(text[len(name):])
        case ast.TimerDecl() | ast.CounterDecl():
            head, _, keyword = text.rstrip().rpartition(" ")
            return _words(head), keyword
        case _:
            assert_never(decl)


def _declarations(line: _Line, width: int) -> str:
    """One declaration: its name in a column; several on one line: one blank apart."""
    parts = [_declaration_parts(line, d) for d in line.nodes]
    if len(parts) != 1:
        return "  ".join(f"{name} {rest}" for name, rest in parts)
    name, rest = parts[0]
    return name.ljust(max(width, len(name) + 1)) + rest


def operator_length(statement: ast.Statement) -> int:
    """How many characters the operator of a statement has (``JC`` of ``JC = end``)."""
    match statement:
        case ast.Logic(op=op) | ast.Store(op=op) | ast.Compare(op=op) | ast.Count(op=op):
            return len(op.value)
        case ast.BlockEnd(kind=kind):
            return len(kind.value)
        case ast.SegmentEnd() | ast.Asm():
            return 3
        case ast.Jump() | ast.CallFB():
            return 2
        case ast.Param():
            return 5
        case ast.Not() | ast.Load() | ast.Transfer() | ast.Arith():
            return 1  # N, L, T, + and -
        case ast.Label():
            return 0
        case _:
            assert_never(statement)


def _statement(line: _Line) -> str:
    """A [PROGRAM] line: label, operator field, operand. A label too long for the label
    column takes one blank and shortens the operator field, so that the operand still
    lines up where it can ("goesoff: L  KT 700")."""
    label = next((n for n in line.nodes if isinstance(n, ast.Label)), None)
    statement = next(
        (n for n in line.nodes if isinstance(n, ast.Statement) and not isinstance(n, ast.Label)),
        None,
    )
    prefix = f"{label.name}:" if label else ""
    if statement is None or statement.span is None:
        return prefix
    span = statement.span
    start = span.column - 1
    length = operator_length(statement)
    operator = line.code[start : start + length]
    rest = line.code[start + length :].strip()
    if isinstance(statement, ast.Jump):
        rest = re.sub(r"^=\s*", "= ", _words(rest))
    elif not isinstance(statement, ast.Asm):
        rest = _words(rest)
    if isinstance(statement, ast.SegmentEnd) and not label:
        return operator
    head = prefix.ljust(INSTRUCTION_COLUMN) if len(prefix) < INSTRUCTION_COLUMN else prefix + " "
    head += operator
    if not rest:
        return head
    return head.ljust(INSTRUCTION_COLUMN + OPERATOR_WIDTH - 1) + " " + rest


# ---------------------------------------------------------------------- comments


def _comment_columns(lines: list[_Line], laid: list[str]) -> dict[int, int]:
    """Per section (by id; None for the lines before the first title): the column its
    comments start in."""
    widths: dict[int, list[int]] = {}
    for line, code in zip(lines, laid, strict=True):
        if code and line.comment:
            widths.setdefault(id(line.section), []).append(len(code))
    return {
        section: max([COMMENT_COLUMN, *(w + 2 for w in found if w + 2 <= COMMENT_LIMIT)])
        for section, found in widths.items()
    }


def _with_comment(code: str, comment: str, column: int) -> str:
    if not comment:
        return code
    return code.ljust(column) + comment if len(code) + 2 <= column else f"{code}  {comment}"
