"""Syntax errors: one test per code (exact place and wording), and recovery.

Reading resumes on the next line after an error, so every error of a file is reported
in one run and the lines around an error still reach the AST.
"""

from __future__ import annotations

import pytest

from asictl.il.ast import (
    BlockEnd,
    DeclSection,
    EndKind,
    Logic,
    LogicOp,
    Operand,
    OperandKind,
    ProgramSection,
    SetupSection,
    SlaveSetup,
    VarDecl,
)
from asictl.il.parser import parse_text

K = OperandKind
op = Operand.of


def errors(text: str) -> list[tuple[int, int, str, str]]:
    _, diagnostics = parse_text(text, "t.asi")
    assert all(d.span.file == "t.asi" and d.is_error for d in diagnostics)
    return [(d.span.line, d.span.column, d.code, d.message) for d in diagnostics]


@pytest.mark.parametrize(
    ("line", "error"),
    [
        ("    A Zähler 1.0", (2, 8, "E101", "unexpected character 'ä'")),
        ("    A I 4.0 \x07", (2, 13, "E101", "unexpected character U+0007")),
        ("    L KB (1)", (2, 10, "E103", "expected a number after 'KB', found '('")),
    ],
    ids=["letter", "control", "parenthesis-is-E103"],
)
def test_e101_unexpected_character(line: str, error: tuple) -> None:
    assert errors(f"[PROGRAM]\n{line}\n") == [error]


@pytest.mark.parametrize(
    ("line", "error"),
    [
        ("    A", (2, 6, "E102", "expected a bit operand (I, I2, Q, F, T, C or a variable) "
                                 "after 'A', found end of line")),
        ("    L   ; load", (2, 6, "E102", "expected an operand (KT, KC, KP, KB, KW, IB, I2B, QB, "
                                          "FY, PSeg, FW, T, C or a variable) after 'L', found "
                                          "end of line")),
        ("    = Q 4", (2, 10, "E102", "expected '.' and a number after '4', found end of line")),
        ("    JC", (2, 7, "E102", "expected '=' and a label, or 'FB' and a block name after "
                                  "'JC', found end of line")),
        ("    CU C", (2, 9, "E102", "expected a number after 'C', found end of line")),
    ],
    ids=["bit-operand", "load-operand", "bit-number", "jump", "counter-number"],
)
def test_e102_unexpected_end_of_line(line: str, error: tuple) -> None:
    assert errors(f"[PROGRAM]\n{line}\n") == [error]


@pytest.mark.parametrize(
    ("text", "error"),
    [
        ("[PROGRAM]\n    O I 4.0 xyz\n", (2, 13, "E103", "expected end of line after '4.0', "
                                                        "found 'xyz'")),
        ("[PROGRAM]\n    T KB 1\n", (2, 7, "E103", "expected a byte or word operand (IB, I2B, "
                                                   "QB, FY, PSeg, FW, T, C or a variable) after "
                                                   "'T', found 'KB'")),
        ("[PROGRAM]\n    CU T 1\n", (2, 8, "E103", "expected 'C' after 'CU', found 'T'")),
        ("[PROGRAM]\n    JU = BE\n", (2, 10, "E103", "expected a name after '=', found 'BE'")),
        ("[PROGRAM]\n    + G\n", (2, 7, "E103", "expected 'F' after '+', found 'G'")),
        ("[SETUP]\n16: ioio 1\n", (2, 5, "E103", "expected an I/O code (a number, or letters "
                                                 "such as iiio) after '16:', found 'ioio'; "
                                                 "the I/O codes are iiii, iiio, iiib, iioo, "
                                                 "iibb, iooo, ibbb, bbbb, oooo, oooi, ooob, "
                                                 "ooii, oobb, oiii, obbb or a number 0..F "
                                                 "(Fh: tristate)")),
        ("[SETUP]\nslave 16\n", (2, 1, "E103", "expected a slave such as '16: iiio, 1, Eh', "
                                               "found 'slave'")),
        ("[OPTIONS]\nauto_start: maybe\n", (2, 13, "E103", "expected yes or no after "
                                                          "'auto_start:', found 'maybe'")),
        ("[GATING]\nQ 1.0 = I 2.0 xor I 3.0\n", (2, 15, "E103", "expected 'and', 'or' or end "
                                                               "of line after '2.0', found 'xor'")),
        ("[DECL]\nCount WORD 2\n", (2, 7, "E103", "expected 'BYTE' or 'FB' after 'Count', "
                                                 "found 'WORD'")),
    ],
    ids=["extra-word", "operand-kind", "keyword", "reserved-name", "arith", "io-code",
         "setup-line-start", "option-value", "gating-operator", "decl-kind"],
)
def test_e103_unexpected_word(text: str, error: tuple) -> None:
    assert errors(text) == [error]


@pytest.mark.parametrize(
    ("line", "error"),
    [
        ("    Q 17.3 = I 4.0", (2, 5, "E104", "unknown instruction 'Q' (a gating line "
                                              "belongs in a [GATING] section)")),
        ("    !x", (2, 5, "E104", "unknown instruction '!'")),
        ("    MOV A,#1", (2, 5, "E104", "unknown instruction 'MOV' (8051 assembler belongs "
                                        "after ASM or in an [ASSEMBLY] section)")),
        ("end BE", (2, 1, "E104", "unknown instruction 'end' (a label is written 'end:')")),
        ("    BEX", (2, 5, "E104", "unknown instruction 'BEX'; did you mean 'BE'?")),
        ("    PARM", (2, 5, "E104", "unknown instruction 'PARM'; did you mean 'PARAM'?")),
        ("    U E 1.0", (2, 5, "E104", "unknown instruction 'U' (STEP 5's German 'U' is 'A' "
                                       "here: 'A I 1.0')")),
        ("    UN M 3.1", (2, 5, "E104", "unknown instruction 'UN' (STEP 5's German 'UN' is "
                                        "'AN' here: 'AN F 3.1')")),
        ("    SPB = x", (2, 5, "E104", "unknown instruction 'SPB' (STEP 5's German 'SPB' is "
                                       "'JC' here: 'JC = x')")),
        ("    LD I 1.0", (2, 5, "E104", "unknown instruction 'LD' (IEC 61131-3's 'LD' is 'A' "
                                        "here)")),
        ("    AND I 1.0", (2, 5, "E104", "unknown instruction 'AND' (IEC 61131-3's 'AND' is "
                                         "'A' here)")),
        ("    ST Q 2.0", (2, 5, "E104", "unknown instruction 'ST' (IEC 61131-3's 'ST' is '=' "
                                        "here)")),
        ("    LD KT 100", (2, 5, "E104", "unknown instruction 'LD' (IEC 61131-3's 'LD' of a "
                                         "constant or a byte is 'L' here)")),
        ("    ST FY 12", (2, 5, "E104", "unknown instruction 'ST' (IEC 61131-3's 'ST' of a "
                                        "constant or a byte is 'T' here)")),
    ],
    ids=["mark", "sign", "assembler", "label-without-colon", "misspelt", "misspelt-long",
         "step5-u", "step5-un-m", "step5-jump", "iec-ld", "iec-and", "iec-st",
         "iec-ld-constant", "iec-st-byte"],
)
def test_e104_unknown_instruction(line: str, error: tuple) -> None:
    assert errors(f"[PROGRAM]\n{line}\n") == [error]


def test_e105_unknown_title_skips_its_section() -> None:
    assert errors(
        "[PROGRAMM]\n"
        "    A I 4.0\n"
        "16: iiio\n"
        "[PROGRAM]\n"
        "    A\n"
    ) == [
        (1, 1, "E105", "unknown section title '[PROGRAMM]'; did you mean [PROGRAM]? (the "
                       "titles: [OPTIONS], [SETUP], [DECL], [PROGRAM], [GATING], [ASSEMBLY], "
                       "[RAW] or [END])"),
        (5, 6, "E102", "expected a bit operand (I, I2, Q, F, T, C or a variable) after 'A', "
                       "found end of line"),
    ]


def test_e106_text_before_the_first_title_is_one_error() -> None:
    module, diagnostics = parse_text(
        "; blink\n"
        "    A T 0\n"
        "    JC = end\n"
        "[PROGRAM]\n"
        "    BE\n"
    )
    assert [(d.span.line, d.span.column, d.code, d.message) for d in diagnostics] == [
        (2, 5, "E106", "expected a section title such as [PROGRAM], found 'A'"),
    ]
    assert module.sections == (ProgramSection((BlockEnd(EndKind.BE),)),)


def test_anything_before_the_first_title_is_one_error() -> None:
    _, diagnostics = parse_text("\x01\x02 binary\n\x03\nA\n[PROGRAM]\n    BE\n")
    assert [(d.span.line, d.code) for d in diagnostics] == [(1, "E101")]


@pytest.mark.parametrize(
    ("line", "error"),
    [
        ("    L KW 1234567890", (2, 10, "E107", "number '1234567890' is too large")),
        ("    L KW 123456789Ah", (2, 10, "E107", "number '123456789Ah' is too large")),
        ("    A F 1.01234567890", (2, 11, "E107", "number '01234567890' is too large")),
    ],
    ids=["decimal", "hexadecimal", "bit-number"],
)
def test_e107_number_too_large(line: str, error: tuple) -> None:
    assert errors(f"[PROGRAM]\n{line}\n") == [error]


def test_every_error_of_a_file_is_reported_and_good_lines_are_kept() -> None:
    module, diagnostics = parse_text(
        "[SETUP]\n"
        "16: iiio, 1\n"
        "17: xyz\n"
        "18: 0, 0\n"
        "[PROGRAM]\n"
        "    A I 1.0\n"
        "    A\n"
        "    O I 2.0\n"
        "    O\n"
        "    BE\n"
    )
    assert [(d.span.line, d.code) for d in diagnostics] == [(3, "E103"), (7, "E102"),
                                                           (9, "E102")]
    assert module.sections == (
        SetupSection((SlaveSetup(16, 1, 1), SlaveSetup(18, 0, 0))),
        ProgramSection((
            Logic(LogicOp.A, op(K.I, 1, 0)),
            Logic(LogicOp.O, op(K.I, 2, 0)),
            BlockEnd(EndKind.BE),
        )),
    )


def test_an_error_on_a_title_line_keeps_the_section() -> None:
    module, diagnostics = parse_text("[DECL] Reading BYTE 5\nCount BYTE 2\n")
    assert [(d.span.line, d.span.column, d.code) for d in diagnostics] == [(1, 8, "E103")]
    assert module.sections == (DeclSection((VarDecl("Count", 2),)),)


def test_errors_on_consecutive_lines() -> None:
    assert [e[:3] for e in errors("[PROGRAM]\n" + "    A\n" * 5 + "    L FY\n")] == [
        (n, 6, "E102") for n in range(2, 7)] + [(7, 9, "E102")]
