"""The lexical rules of docs/language.md, one by one."""

from __future__ import annotations

import pytest

from asictl.diagnostics import Span
from asictl.il.ast import (
    AsmLine,
    AssemblySection,
    BlockEnd,
    CallFB,
    CounterDecl,
    DeclSection,
    EndKind,
    FBDecl,
    GatingLine,
    GatingOp,
    GatingSection,
    GatingTerm,
    Jump,
    Label,
    Load,
    Logic,
    LogicOp,
    Module,
    Not,
    Operand,
    OperandKind,
    Option,
    OptionsSection,
    ProgramSection,
    RawSection,
    SetupSection,
    SlaveSetup,
    Store,
    StoreOp,
    TimerDecl,
    Transfer,
    VarDecl,
)
from asictl.il.parser import parse, parse_text
from asictl.source import from_bytes

K = OperandKind
op = Operand.of


def clean(text: str) -> tuple:
    module, diagnostics = parse_text(text)
    assert diagnostics == []
    return module.sections


def program(*lines: str) -> tuple:
    """The statements of a [PROGRAM] section holding ``lines``."""
    (section,) = clean("[PROGRAM]\n" + "".join(f"    {line}\n" for line in lines))
    return section.statements


A_I_4_0 = Logic(LogicOp.A, op(K.I, 4, 0))


# ------------------------------------------------------------------ comments, case


def test_comments_run_from_semicolon_to_end_of_line() -> None:
    assert clean(
        "; a file comment\n"
        "[PROGRAM] ; the program\n"
        "    A I 4.0;no blank needed\n"
        "   ; a comment line, indented\n"
        "\n"
        "    BE ; = Q 1.0 is a comment here\n"
    ) == (ProgramSection((A_I_4_0, BlockEnd(EndKind.BE))),)


def test_case_is_ignored_and_names_keep_their_spelling() -> None:
    assert clean(
        "[program]\n"
        "Loop: a i 4.0\n"
        "      an Reading 0.1\n"
        "      ju = LOOP\n"
        "      ju fb setpp\n"
        "[Gating]\n"
        "q 1.0 = I 4.0 AND NOT f 1.1 Or N reading 0.2\n"
    ) == (
        ProgramSection((
            Label("Loop"), A_I_4_0,
            Logic(LogicOp.AN, op(K.VAR, 0, 1, name="Reading")),
            Jump(False, "LOOP"), CallFB(False, "setpp"),
        )),
        GatingSection((GatingLine(op(K.Q, 1, 0), (
            GatingTerm(None, False, op(K.I, 4, 0)),
            GatingTerm(GatingOp.AND, True, op(K.F, 1, 1)),
            GatingTerm(GatingOp.OR, True, op(K.VAR, 0, 2, name="reading")),
        )),)),
    )


# ------------------------------------------------------------------- punctuation


@pytest.mark.parametrize("operand", ["I 4.0", "I4.0", "I 4 0", "I 4,0", "I 4 . 0", "i4 0"])
def test_bit_operand_spellings(operand: str) -> None:
    assert program(f"A {operand}") == (A_I_4_0,)


@pytest.mark.parametrize(
    ("operand", "read"),
    [
        ("I2 4.0", op(K.I2, 4, 0)),
        ("I2,4.0", op(K.I2, 4, 0)),
        ("I2.0", op(K.I, 2, 0)),
        ("I20.1", op(K.I, 20, 1)),
        ("F42.7", op(K.F, 42, 7)),
        ("Reading 3 2", op(K.VAR, 3, 2, name="Reading")),
    ],
)
def test_glued_marks(operand: str, read: object) -> None:
    assert program(f"O {operand}") == (Logic(LogicOp.O, read),)


def test_glued_byte_word_and_constant_marks() -> None:
    assert program("L FY1", "L FW10", "L KT500", "L KP13.9", "L KB0Ah", "T PSeg0", "L IB4",
                   "L I2B4", "L Reading 3") == (
        Load(op(K.FY, 1)), Load(op(K.FW, 10)),
        Load(op(K.KT, 500)), Load(op(K.KP, 13, 9)),
        Load(op(K.KB, 10)), Transfer(op(K.PSEG, 0)),
        Load(op(K.IB, 4)), Load(op(K.I2B, 4)),
        Load(op(K.VAR, 3, name="Reading")),
    )


def test_a_mark_followed_by_a_letter_is_a_name() -> None:
    assert program("A Ix 1.0", "L Temp 0", "S Count 2.1") == (
        Logic(LogicOp.A, op(K.VAR, 1, 0, name="Ix")), Load(op(K.VAR, 0, name="Temp")),
        Store(StoreOp.SET, op(K.VAR, 2, 1, name="Count")),
    )


@pytest.mark.parametrize("line", ["16: iiio, 1, Eh", "16 iiio 1 Eh", "16:iiio,1,Eh,",
                                  "16: 1h, 1, 14", "16: 1, 1d, 0Eh"])
def test_setup_spellings(line: str) -> None:
    assert clean(f"[SETUP]\n{line}\n") == (SetupSection((SlaveSetup(16, 1, 1, 14),)),)


@pytest.mark.parametrize(("letters", "code"), [("iiii", 0), ("iiio", 1), ("IIIB", 2),
                                               ("oooo", 8), ("ooob", 0xA), ("obbb", 0xE)])
def test_io_code_letters_list_d0_to_d3(letters: str, code: int) -> None:
    assert clean(f"[SETUP]\n1: {letters}, 0\n") == (SetupSection((SlaveSetup(1, code, 0),)),)


@pytest.mark.parametrize(("value", "flag"), [("yes", True), ("ON", True), ("true", True),
                                             ("no", False), ("Off", False), ("FALSE", False)])
def test_option_values(value: str, flag: bool) -> None:
    assert clean(f"[OPTIONS]\nmap_counters {value}\n") == (
        OptionsSection((Option("map_counters", flag),)),)


def test_other_punctuation_reads_as_a_blank() -> None:
    assert program('A "I 4.0"', "A I 4.0 ,", "A I/4/0", "N ??") == (A_I_4_0,) * 3 + (Not(),)


# ------------------------------------------------------------------------ numbers


@pytest.mark.parametrize(
    ("number", "value"),
    [("12", 12), ("16d", 16), ("0Ah", 10), ("Eh", 14), ("FFh", 255), ("0ffh", 255),
     ("00000000000012", 12), ("FFFFh", 65535), ("999999999", 999999999)],
)
def test_numbers(number: str, value: int) -> None:
    assert program(f"L KW {number}") == (Load(op(K.KW, value)),)


# ---------------------------------------------------------------- source encoding


@pytest.mark.parametrize("comment", [b"Z\x84hler", b"Sch\xe4tzung"], ids=["cp850", "latin-1"])
def test_dos_text_crlf_ctrl_z_and_8_bit_comments(comment: bytes) -> None:
    raw = (b"[PROGRAM]\r\n"
           b"    A I 4.0   ; " + comment + b"\r\n"
           b"    = Q 1.0\r\n"
           b"\x1a[GARBAGE after the DOS end-of-file mark")
    module, diagnostics = parse(from_bytes("dos.asi", raw))
    assert diagnostics == []
    assert module.sections == (ProgramSection((
        A_I_4_0, Store(StoreOp.ASSIGN, op(K.Q, 1, 0)))),)
    assert module.sections[0].statements[1].span == Span("dos.asi", 3, 5, 7)


def test_a_file_without_final_line_end() -> None:
    assert clean("[PROGRAM]\n    BE") == (ProgramSection((BlockEnd(EndKind.BE),)),)


@pytest.mark.parametrize("text", ["", "\n\n", "; only a comment", "   \n\t; x\n"])
def test_empty_files(text: str) -> None:
    assert parse_text(text) == (Module("<string>", ()), [])


# ------------------------------------------------------------------------- titles


@pytest.mark.parametrize("title", ["[DECL]", "[DECLARATION]", "[Declarations]", "[ decl ]"])
def test_declaration_titles(title: str) -> None:
    assert clean(f"{title}\nx BYTE 1\n") == (DeclSection((VarDecl("x", 1),)),)


@pytest.mark.parametrize("title", ["[ASSEMBLY]", "[ASM]", "[Assembly]"])
def test_assembly_titles(title: str) -> None:
    assert clean(f"{title}\n  nop\n") == (AssemblySection((AsmLine("nop"),)),)


def test_titles_without_brackets_alone_in_the_first_column() -> None:
    assert clean(
        "OPTIONS\n"
        "auto_start: no\n"
        "Setup ; Control I\n"
        "1: iiii, 0\n"
        "PROGRAM\n"
        "    A I 4.0\n"
        "GATING\n"
        "Q 1.0 = I 4.0\n"
        "END\n"
        "whatever\n"
    ) == (
        OptionsSection((Option("auto_start", False),)),
        SetupSection((SlaveSetup(1, 0, 0),)),
        ProgramSection((A_I_4_0,)),
        GatingSection((GatingLine(op(K.Q, 1, 0), (
            GatingTerm(None, False, op(K.I, 4, 0)),)),)),
    )


def test_a_title_without_brackets_must_start_the_line() -> None:
    _, diagnostics = parse_text("[PROGRAM]\n    PROGRAM\n")
    assert [(d.code, d.span.column) for d in diagnostics] == [("E104", 5)]


def test_only_control_i_titles_go_without_brackets() -> None:
    _, diagnostics = parse_text("DECL\n")
    assert [d.code for d in diagnostics] == ["E106"]


def test_end_as_label_is_no_title() -> None:
    assert program("JU = end") + clean("[PROGRAM]\nend: BE\nEND:\n")[0].statements == (
        Jump(False, "end"), Label("end"), BlockEnd(EndKind.BE), Label("END"))


def test_everything_after_end_is_ignored() -> None:
    assert clean(
        "[PROGRAM]\n    A I 4.0\n[End] trailing words\n[FOO]\n    A\n\x00\xff\n"
    ) == (ProgramSection((A_I_4_0,)),)


def test_several_sections_run_in_source_order() -> None:
    sections = clean(
        "[SETUP]\n1: 0, 0\n[PROGRAM]\n    N\n[GATING]\n[PROGRAM]\n    BE\n[SETUP]\n2: 0, 0\n"
    )
    assert sections == (
        SetupSection((SlaveSetup(1, 0, 0),)), ProgramSection((Not(),)), GatingSection(()),
        ProgramSection((BlockEnd(EndKind.BE),)), SetupSection((SlaveSetup(2, 0, 0),)),
    )


# ------------------------------------------------------------------ program lines


def test_label_alone_and_with_an_instruction() -> None:
    assert program("start:", "loop : A I 4.0", "JC loop", "JU = start") == (
        Label("start"), Label("loop"), A_I_4_0, Jump(True, "loop"), Jump(False, "start"))


def test_asm_operator_takes_the_rest_of_the_line_up_to_the_comment() -> None:
    (asm,) = program("ASM   mov a, #12h  ; load 12h")
    assert asm.text == "mov a, #12h"


def test_several_declarations_on_a_line() -> None:
    assert clean("[DECL]\nx BYTE 2 T20 TIMER C 30 COUNTER avg FB avg.fb y BYTE 1\n") == (
        DeclSection((VarDecl("x", 2), TimerDecl(20), CounterDecl(30), FBDecl("avg", "avg.fb"),
                     VarDecl("y", 1))),)


# ----------------------------------------------------------- assembly and raw lines


def test_assembly_lines_are_passed_on_and_only_a_bracketed_title_ends_them() -> None:
    assert clean(
        "[ASM]\n"
        "$MOD51\n"
        "loop:   mov   a,#';'   ; the comment goes\n"
        "END\n"
        "    [PROGRAM]\n"
        "    BE\n"
    ) == (
        AssemblySection((AsmLine("$MOD51"), AsmLine("loop:   mov   a,#'"), AsmLine("END"))),
        ProgramSection((BlockEnd(EndKind.BE),)),
    )


def test_raw_records() -> None:
    assert clean("[RAW]\n:0300000002003BC0 ; first\n:00000001FF\n") == (
        RawSection((":0300000002003BC0", ":00000001FF")),)


# -------------------------------------------------------------------------- spans


def test_spans_point_at_operator_and_mark() -> None:
    (logic,) = program("AN  Q  31.0")
    assert (logic.span.line, logic.span.column, logic.span.length) == (2, 5, 11)
    assert (logic.operand.span.column, logic.operand.span.length) == (9, 7)
