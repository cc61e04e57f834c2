"""Completion: what may be typed at the cursor, read from the line typed so far.

The line being typed rarely parses, so the context is read from the text: the section
(the last title above the cursor) and the words before the cursor on its line. What the
program declares (slaves, variables, labels, blocks) comes from the last analysis.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from asictl.il import ast
from asictl.il.references import SymbolKind
from asictl.lsp.documents import Analysis
from asictl.lsp.texts import (
    INSTRUCTIONS,
    IO_LETTERS,
    OPERANDS,
    OPTION_VALUES,
    OPTIONS,
    SECTIONS,
    io_code_text,
)
from asictl.runtime.firmware import FIRMWARE_BLOCKS


@dataclass(frozen=True)
class Item:
    label: str
    #: "keyword", "operand", "slave", "variable", "label", "block", "section", "option",
    #: "value" (the server maps these to the editor's kinds)
    kind: str
    detail: str = ""
    documentation: str = ""
    #: what to insert instead of the label
    insert: str | None = None


_TITLE = re.compile(
    r"^\s*\[\s*(options|setup|decl\w*|program|gating|assembly|asm|raw|end)\s*\]"
    r"|^(options|setup|program|gating|end)\s*(?:;|$)", re.IGNORECASE)
_LABEL = re.compile(r"^\s*[A-Za-z_]\w*\s*:\s*")
_BIT_MARKS = ("I", "I2", "Q", "F", "T", "C")
_LOAD_MARKS = ("KT", "KC", "KP", "KB", "KW", "IB", "I2B", "QB", "FY", "FW", "PSEG", "T", "C")
_TRANSFER_MARKS = ("QB", "FY", "FW", "PSEG", "T", "C")


def section_at(lines: list[str], line: int) -> str | None:
    """The section the 1-based ``line`` is in (its canonical name), from the titles above."""
    for text in reversed(lines[: line - 1]):
        match = _TITLE.match(text)
        if match:
            word = (match.group(1) or match.group(2)).upper()
            return {"ASM": "ASSEMBLY"}.get(word, "DECL" if word.startswith("DECL") else word)
    return None


def complete(analysis: Analysis | None, file: str, lines: list[str], line: int, column: int
             ) -> list[Item]:
    """The items for the cursor before 1-based ``column`` of 1-based ``line`` of the
    text's ``lines``."""
    before = lines[line - 1][: column - 1] if 0 < line <= len(lines) else ""
    if ";" in before:
        return []  # in a comment
    section = section_at(lines, line)
    if before.lstrip().startswith("[") or (not before and section is None):
        return _sections()
    titles = _sections() if not before else []
    words = before.split()
    typing_word = bool(before) and not before[-1].isspace()
    done = words[:-1] if typing_word else words
    match section:
        case "PROGRAM":
            return _program(analysis, file, _LABEL.sub("", before), typing_word) + titles
        case "GATING":
            return _operands(analysis, _BIT_MARKS) + _keywords(("and", "or", "not")) if done \
                else _operands(analysis, _BIT_MARKS)
        case "OPTIONS":
            return _option_values() if done else _option_names()
        case "SETUP":
            return _io_codes() if len(done) == 1 else _slaves(analysis) if not done else []
        case "DECL":
            return _keywords(("BYTE", "FB", "TIMER", "COUNTER")) if len(done) % 3 == 1 else []
    return _sections() if not before.strip() else []


def _program(analysis: Analysis | None, file: str, before: str, typing_word: bool) -> list[Item]:
    words = before.split()
    done = words[:-1] if typing_word else words
    if not done:
        return _instructions()
    operator = done[0].upper()
    if operator in ("JU", "JC"):
        if len(done) >= 2 and done[1].upper() == "FB":
            return _blocks(analysis)
        if "=" in before:
            return _labels(analysis, file)
        if len(done) >= 2:
            return []
        return [*_keywords(("FB",)), Item("=", "keyword", "jump to a label", insert="= "),
                *_labels(analysis, file)]
    if operator in ("CU", "CD", "STP"):
        return _operands(analysis, ("C",), variables=False)
    if operator in ("+", "-", "!=", "><", ">", ">=", "<", "<="):
        return _keywords(("F",))
    marks = {"L": _LOAD_MARKS, "T": _TRANSFER_MARKS}.get(operator, _BIT_MARKS)
    if len(done) >= 2 and done[1].upper() in ("I", "I2", "Q", "IB", "I2B", "QB", "KP"):
        return _slave_bits(analysis, done[1].upper())
    return _operands(analysis, marks) if len(done) == 1 else []


# ------------------------------------------------------------------------ items


def _sections() -> list[Item]:
    return [Item(e.syntax, "section", e.meaning) for e in SECTIONS.values()]


def _instructions() -> list[Item]:
    return [Item(op, "keyword", e.syntax, e.meaning) for op, e in INSTRUCTIONS.items()]


def _keywords(words: tuple[str, ...]) -> list[Item]:
    return [Item(w, "keyword") for w in words]


def _operands(analysis: Analysis | None, marks: tuple[str, ...], variables: bool = True
              ) -> list[Item]:
    items = [Item(OPERANDS[m].syntax.split(" ")[0], "operand", OPERANDS[m].syntax,
                  OPERANDS[m].meaning) for m in marks]
    if variables and analysis is not None:
        for module in analysis.result.program.modules():
            for section in module.sections_of(ast.DeclSection):
                items += [Item(d.name, "variable", d.to_source(), "declared variable")
                          for d in section.declarations if isinstance(d, ast.VarDecl)]
    return items


def _setup(analysis: Analysis | None) -> list[ast.SlaveSetup]:
    if analysis is None:
        return []
    return [s for section in analysis.result.program.main.sections_of(ast.SetupSection)
            for s in section.slaves]


def _slaves(analysis: Analysis | None) -> list[Item]:
    return [Item(str(s.address), "slave", s.to_source()) for s in _setup(analysis)]


def _slave_bits(analysis: Analysis | None, mark: str) -> list[Item]:
    """Slave addresses from [SETUP]: the data bits an I, I2 or Q operand may take there
    (inputs, outputs or bidirectional bits by the I/O code), or the even addresses of a
    byte."""
    items = []
    for slave in _setup(analysis):
        if mark in ("IB", "I2B", "QB"):
            if slave.address % 2 == 0:
                items.append(Item(str(slave.address), "slave", slave.to_source()))
            continue
        if mark == "KP":
            items.append(Item(f"{slave.address}.", "slave", slave.to_source()))
            continue
        letters = IO_LETTERS[slave.io_code] if slave.io_code < len(IO_LETTERS) else "bbbb"
        wanted = "ob" if mark == "Q" else "ib"
        items += [
            Item(f"{slave.address}.{bit}", "slave", f"slave {slave.address} D{bit}",
                 f"[SETUP] `{slave.to_source()}`: I/O code {io_code_text(slave.io_code)}")
            for bit, letter in enumerate(letters) if letter in wanted
        ]
    return items


def _labels(analysis: Analysis | None, file: str) -> list[Item]:
    if analysis is None:
        return []
    module = analysis.module(file)
    if module is None:
        return []
    return [Item(s.name, "label", f"line {s.span.line}" if s.span else "")
            for s in module.statements() if isinstance(s, ast.Label)]


def _blocks(analysis: Analysis | None) -> list[Item]:
    items = []
    if analysis is not None:
        for symbol in analysis.index.symbols(SymbolKind.BLOCK):
            declared = [o.node for o in analysis.index.of(symbol)
                        if isinstance(o.node, ast.FBDecl)]
            if declared:
                items.append(Item(declared[0].name, "block", declared[0].to_source()))
    items += [Item(b.name, "block", "firmware block", b.description)
              for b in FIRMWARE_BLOCKS.values()]
    return items


def _option_names() -> list[Item]:
    return [Item(name, "option", f"default {e.syntax}", e.meaning, insert=f"{name}: ")
            for name, e in OPTIONS.items()]


def _option_values() -> list[Item]:
    return [Item(v, "value") for v in OPTION_VALUES]


def _io_codes() -> list[Item]:
    return [Item(letters, "value", io_code_text(code)) for code, letters in enumerate(IO_LETTERS)]
