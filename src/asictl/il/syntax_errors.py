"""Syntax errors as a modern compiler words them, from lark's parse exceptions.

Lark reports which terminals the parser state could have taken; this module turns that
into "expected a bit operand (...) after 'A', found end of line", with a code per class
of error (the table below, also in docs/language.md). The found word is read from the
source rather than from lark's token: after an unexpected character, lark's contextual
lexer re-lexes with every terminal of the grammar, and its idea of the next token
(often the rest of the line, as assembler text) is no help to a reader.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from asictl.codes import SyntaxCode
from asictl.diagnostics import Diagnostic, Severity, Span
from asictl.il.ast import SectionKind
from asictl.il.foreign import operand_hint, operator_hint
from asictl.platform.master import IO_CODE_BITS
from asictl.readers.suggest import closest, did_you_mean

#: Punctuation the language reads as a blank (3: only some punctuation is significant).
IGNORED_PUNCTUATION = "\"#$%&',/?@\\^`{|}~"
_SIGNIFICANT = set("*=()[].:+-!<>;_")
_BLANKS = " \t\f\v"

_FOUND = re.compile(r"\[[^\]]*\]?|[A-Za-z0-9_]+|\*+|[!<>=]+|.", re.DOTALL)
_NUMBER_LIKE = re.compile(r"[0-9]+d?|[0-9a-f]+h", re.IGNORECASE)
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")

#: The sample line each section expects, for errors at the start of a line.
_LINE_STARTS = {
    SectionKind.OPTIONS: "an option such as 'auto_start: yes'",
    SectionKind.SETUP: "a slave such as '16: iiio, 1, Eh'",
    SectionKind.DECL: "a declaration such as 'Reading BYTE 5'",
    SectionKind.GATING: "a gating line such as 'Q 17.3 = I 4.0'",
    SectionKind.ASSEMBLY: "an assembler line",
    SectionKind.RAW: "an Intel HEX record",
}

_TITLES = "[OPTIONS], [SETUP], [DECL], [PROGRAM], [GATING], [ASSEMBLY], [RAW] or [END]"
_TITLE_WORDS = ("OPTIONS", "SETUP", "DECL", "PROGRAM", "GATING", "ASSEMBLY", "RAW", "END")
_IO_CODES = (
    ", ".join(letters for letters in IO_CODE_BITS if "t" not in letters)
    + " or a number 0..F (Fh: tristate)"
)
#: The first word of the rest of a line, to see whether it is an instruction.
_FIRST_WORD = re.compile(r"[ \t]*([A-Za-z]+|[=+\-!<>]+|\*\*\*)")

MARK_WORDS = {
    "I_MARK": "I", "I2_MARK": "I2", "Q_MARK": "Q", "F_MARK": "F", "T_MARK": "T",
    "C_MARK": "C", "IB_MARK": "IB", "I2B_MARK": "I2B", "QB_MARK": "QB", "FY_MARK": "FY",
    "FW_MARK": "FW", "PSEG_MARK": "PSeg", "KT_MARK": "KT", "KC_MARK": "KC",
    "KP_MARK": "KP", "KB_MARK": "KB", "KW_MARK": "KW",
}


def _marks(*words: str) -> frozenset[str]:
    by_word = {word: name for name, word in MARK_WORDS.items()}
    return frozenset(by_word[w] for w in words)


_BIT_MARKS = _marks("I", "I2", "Q", "F", "T", "C")
_BYTE_WORD_MARKS = _marks("IB", "I2B", "QB", "FY", "PSeg", "FW", "T", "C")

#: The operators that can start a [PROGRAM] instruction.
_OPERATORS = frozenset(
    [
        "A", "AN", "O", "ON", "EQ", "S", "R", "N", "L", "T", "PLUS", "MINUS", "CMP_EQ",
        "CMP_NE", "CMP_GT", "CMP_GE", "CMP_LT", "CMP_LE", "CU", "CD", "STP", "SEGMENT_END",
        "BE", "BEC", "BEU", "JU", "JC", "PARAM", "ASM",
    ]
)

#: Sets of terminals that read better as one phrase, tried in this order.
_GROUPS: tuple[tuple[frozenset[str], str], ...] = (
    (_OPERATORS, "an instruction"),
    (_BIT_MARKS | {"NAME"}, "a bit operand (I, I2, Q, F, T, C or a variable)"),
    (
        _BYTE_WORD_MARKS | _marks("KT", "KC", "KP", "KB", "KW") | {"NAME"},
        "an operand (KT, KC, KP, KB, KW, IB, I2B, QB, FY, PSeg, FW, T, C or a variable)",
    ),
    (_BYTE_WORD_MARKS | {"NAME"}, "a byte or word operand (IB, I2B, QB, FY, PSeg, FW, T, C "
     "or a variable)"),
    (frozenset({"NAME", "T_MARK", "C_MARK"}), "another declaration"),
    (frozenset({"EQ", "FB", "NAME"}), "'=' and a label, or 'FB' and a block name"),
    (frozenset({"NUMBER", "IO_CODE"}), "an I/O code (a number, or letters such as iiio)"),
    (frozenset({"_DOT", "NUMBER"}), "'.' and a number"),
    (frozenset({"NOT", "N"}), "'not'"),
)

_SINGLES = {
    "NUMBER": "a number",
    "NAME": "a name",
    "BOOL": "yes or no",
    "FILE_NAME": "a file name",
    "ASM_TEXT": "assembler text",
    "ASM_LINE": "an assembler line",
    "RAW_RECORD": "an Intel HEX record",
    "_COLON": "':'",
    "_DOT": "'.'",
    "_NL": "end of line",
}
_NOT_LISTED = frozenset({"$END", "END_REST"})


@dataclass(frozen=True)
class Diagnosis:
    """A diagnosed error, and whether reading resumes on the next line or the next title."""

    diagnostic: Diagnostic
    #: Go on at the next section title: the lines up to it belong to no known section.
    skip_to_title: bool


def describe(expected: frozenset[str], keywords: dict[str, str]) -> str:
    """Say in words what a set of terminal names stands for.

    ``keywords`` maps the names of keyword terminals to their spelling (``BYTE`` ->
    ``BYTE``, ``CMP_GE`` -> ``>=``).
    """
    rest = {t for t in expected if t not in _NOT_LISTED and not t.endswith("_TITLE")}
    phrases = []
    for group, phrase in _GROUPS:
        if group <= rest:
            phrases.append(phrase)
            rest -= group
    line_end = "_NL" in rest
    rest.discard("_NL")
    phrases += sorted(_single(t, keywords) for t in rest)
    if line_end:
        phrases.append(_SINGLES["_NL"])
    if not phrases:
        return "a section title"
    return phrases[0] if len(phrases) == 1 else ", ".join(phrases[:-1]) + " or " + phrases[-1]


def _single(terminal: str, keywords: dict[str, str]) -> str:
    if terminal in _SINGLES:
        return _SINGLES[terminal]
    return f"'{MARK_WORDS.get(terminal) or keywords[terminal]}'"


def _last_word(before: str) -> str:
    words = before.split()
    return _quote(words[-1]) if words else "the start of the line"


def _quote(word: str) -> str:
    return f"'{word}'" if len(word) <= 40 else f"'{word[:37]}...'"


def diagnose(
    text: str,
    pos: int,
    line: int,
    expected: frozenset[str],
    keywords: dict[str, str],
    file: str,
    section: SectionKind | None,
) -> Diagnosis:
    """Classify a parse error at offset ``pos`` (on line ``line``) of ``text``.

    ``expected`` holds the terminals the parser could have taken there, ``keywords`` the
    spelling of keyword terminals, ``section`` the section the line belongs to (None:
    before the first title).
    """
    line_start = text.rfind("\n", 0, pos) + 1
    before = text[line_start:pos]
    said = before.rstrip(_BLANKS + IGNORED_PUNCTUATION)
    rest = text[pos:text.index("\n", pos)].partition(";")[0]
    # _FOUND's last alternative takes any character, so it matches wherever rest has text.
    found_match = _FOUND.match(rest) if rest.strip(_BLANKS + IGNORED_PUNCTUATION) else None
    found = found_match.group() if found_match else ""
    char = text[pos]

    def report(code: str, message: str, at: int = pos, length: int = len(found)) -> Diagnosis:
        # Lines outside any known section are skipped up to the next title, unreported.
        skip = section is None or code == SyntaxCode.UNKNOWN_SECTION
        span = Span(file, line, at - line_start + 1, max(1, length))
        return Diagnosis(Diagnostic(Severity.ERROR, code, message, span), skip)

    if found and not (char.isascii() and (char.isalnum() or char in _SIGNIFICANT)):
        shown = f"'{char}'" if char.isprintable() else f"U+{ord(char):04X}"
        return report(SyntaxCode.UNEXPECTED_CHARACTER, f"unexpected character {shown}")
    if not said and found.startswith("["):
        title = closest(found.strip("[] \t"), _TITLE_WORDS)
        hint = f"; did you mean [{title}]? (the titles: {_TITLES})" if title else (
            f"; expected {_TITLES}")
        return report(SyntaxCode.UNKNOWN_SECTION, f"unknown section title {_quote(found)}{hint}")
    if section is None:
        return report(
            SyntaxCode.MISSING_SECTION, "expected a section title such as [PROGRAM], found "
            f"{_quote(found) if found else 'end of line'}")
    if "NUMBER" in expected and _NUMBER_LIKE.fullmatch(found):
        return report(SyntaxCode.NUMBER_TOO_LARGE, f"number {_quote(found)} is too large")
    operators = [keywords[t] for t in sorted(_OPERATORS) if t in keywords]
    if section is SectionKind.PROGRAM and expected == {"_COLON"}:
        # A line that starts with a name where an instruction belongs: a misspelt or
        # foreign operator, or a label without its ':'.
        name = _NAME.search(before)
        assert name is not None  # the parser read a name to get here
        word = name.group()
        code = text[line_start + name.start():text.index("\n", pos)].partition(";")[0]
        return report(
            SyntaxCode.UNKNOWN_INSTRUCTION,
            f"unknown instruction {_quote(word)}"
            + _instruction_hint(word, code, text[line_start + name.end():pos] + rest, operators),
            at=line_start + name.start(), length=len(word))
    if not found:
        return report(
            SyntaxCode.UNEXPECTED_END_OF_LINE, f"expected {describe(expected, keywords)} after "
            f"{_last_word(said)}, found end of line", at=line_start + len(said))
    if section is SectionKind.PROGRAM and (not said or expected >= _OPERATORS):
        hint = ""
        if not said and found.upper() in ("I", "I2", "Q", "F") and "=" in rest:
            hint = " (a gating line belongs in a [GATING] section)"
        elif not said:
            foreign = operator_hint(found, rest)
            hint = f" ({foreign})" if foreign else did_you_mean(found, operators)
        return report(SyntaxCode.UNKNOWN_INSTRUCTION, f"unknown instruction {_quote(found)}{hint}")
    if not said:
        return report(
            SyntaxCode.UNEXPECTED_WORD, f"expected {_LINE_STARTS[section]}, found {_quote(found)}")
    message = (f"expected {describe(expected, keywords)} after {_last_word(said)}, "
               f"found {_quote(found)}")
    if "IO_CODE" in expected:
        message += f"; the I/O codes are {_IO_CODES}"
    elif expected & _BIT_MARKS and (german := operand_hint(found)):
        message += f" ({german})"
    return report(SyntaxCode.UNEXPECTED_WORD, message)


def _instruction_hint(word: str, code: str, rest: str, operators: list[str]) -> str:
    """Why a line's first word is no instruction: a foreign operator, a misspelt one, or a
    label without ':' (only when an instruction, or nothing, follows the word)."""
    foreign = operator_hint(word, code)
    if foreign:
        return f" ({foreign})"
    follows = _FIRST_WORD.match(rest)
    label_like = follows is None or follows.group(1).upper() in operators
    if follows is None:  # the word alone on its line: a misspelt BE rather than a label
        close = closest(word, operators, cutoff=0.6)
        if close:
            return f"; did you mean '{close}'?"
    if label_like:
        return f" (a label is written '{word}:')"
    return did_you_mean(word, operators)
