"""Every example program of the programming manual (chapter 3) reads to the exact AST.

The manual's text extraction scrambled some tables; the sources below are the
reconstructions docs/language.md describes (one instruction per line, I2 where the
extraction reads "12", the underscore of MEAN_VALUE restored).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from manual_examples import EXAMPLES

from asictl.diagnostics import Span
from asictl.il.ast import (
    Arith,
    ArithOp,
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
    Param,
    ProgramSection,
    SegmentEnd,
    SetupSection,
    SlaveSetup,
    Store,
    StoreOp,
    TimerDecl,
    Transfer,
    VarDecl,
)
from asictl.il.parser import parse_text
from asictl.source import read_source

ROOT = Path(__file__).resolve().parents[2]
DEMOS = ROOT / "demos"

K = OperandKind
op = Operand.of


def read(text: str) -> tuple:
    module, diagnostics = parse_text(text, "example.asi")
    assert diagnostics == []
    return module.sections


def test_options_example() -> None:  # 3.1
    assert read(EXAMPLES["options"]) == (
        OptionsSection((Option("ignore_config_errors", True), Option("auto_start", False))),
    )


def test_setup_example() -> None:  # 3.2
    assert read(EXAMPLES["setup"]) == (
        SetupSection((SlaveSetup(16, 1, 1, 14), SlaveSetup(3, 0xB, 0, None))),
    )


DECL_AST = (
    DeclSection((
        VarDecl("Reading", 5), TimerDecl(134), CounterDecl(27), FBDecl("MEAN_VALUE", "MEAN.FB"),
    )),
)


def test_declaration_example() -> None:  # 3.3, one declaration per line
    assert read(EXAMPLES["declaration"]) == DECL_AST


def test_declaration_example_on_one_line() -> None:
    """The extraction's single line, once the title stands on its own line."""
    assert read(
        "[DECL]\nReading BYTE 5 T134 TIMER C27 COUNTER MEAN_VALUE FB MEAN.FB\n"
    ) == DECL_AST


def test_declaration_example_as_extracted() -> None:
    """Verbatim, the line has text after its title: one error, the line is dropped."""
    module, diagnostics = parse_text(
        "[DECL] Reading BYTE 5 T134 TIMER C27 COUNTER MEAN VALUE FB MEAN.FB\n", "x.asi"
    )
    assert [(d.code, d.span.column, d.message) for d in diagnostics] == [
        ("E103", 8, "expected end of line after '[DECL]', found 'Reading'"),
    ]
    assert module.sections == (DeclSection(()),)


def test_or_and_not_network() -> None:  # 3.4.1
    assert read(EXAMPLES["or_and_not"]) == (ProgramSection((
        Logic(LogicOp.O, op(K.I, 4, 0)),
        Logic(LogicOp.O, op(K.I, 5, 0)),
        Logic(LogicOp.AN, op(K.F, 42, 7)),
        Store(StoreOp.ASSIGN, op(K.Q, 17, 3)),
        SegmentEnd(),
    )),)


def test_subtraction() -> None:  # 3.4.2
    assert read(EXAMPLES["subtraction"]) == (ProgramSection((
        Load(op(K.FY, 1)),
        Load(op(K.FY, 2)),
        Arith(ArithOp.SUB),
        Transfer(op(K.FY, 3)),
        SegmentEnd(),
    )),)


BLINK = (
    Logic(LogicOp.A, op(K.T, 0)),
    Jump(True, "end"),
    Not(),
    Load(op(K.KT, 500)),
    Store(StoreOp.SET, op(K.T, 0)),
    SegmentEnd(),
    Logic(LogicOp.AN, op(K.Q, 31, 0)),
    Store(StoreOp.ASSIGN, op(K.Q, 31, 0)),
    Label("end"),
    BlockEnd(EndKind.BE),
)


def test_blink_1hz() -> None:  # 3.4.2
    text = EXAMPLES["blink"]
    assert read(text) == (ProgramSection(BLINK),)
    statements = read(text)[0].statements
    assert statements[1].span == Span("example.asi", 3, 9, 9)  # "JC  = end"
    assert statements[6].operand.span == Span("example.asi", 8, 13, 6)  # "Q 31.0"
    assert statements[8].span == Span("example.asi", 10, 1, 3)  # the label
    assert statements[9].span == Span("example.asi", 10, 9, 2)  # BE, same line


def test_blink_demo() -> None:
    module, diagnostics = parse_text(read_source(DEMOS / "blink.asi").text, "blink.asi")
    assert diagnostics == []
    assert module == Module("blink.asi", (
        OptionsSection((Option("auto_start", True),)),
        SetupSection((SlaveSetup(31, 8, 0),)),
        ProgramSection(BLINK),
    ))


def test_param_edges() -> None:  # 3.4.6
    assert read(EXAMPLES["param_edges"]) == (ProgramSection((
        Logic(LogicOp.A, op(K.I, 12, 0)),
        Logic(LogicOp.AN, op(K.I2, 12, 0)),
        Load(op(K.KP, 13, 3)),
        Param(),
        SegmentEnd(),
        Logic(LogicOp.A, op(K.I2, 12, 0)),
        Logic(LogicOp.AN, op(K.I, 12, 0)),
        Load(op(K.KP, 13, 12)),
        Param(),
        SegmentEnd(),
    )),)


GATING = (GatingSection((
    GatingLine(op(K.Q, 17, 3), (
        GatingTerm(None, False, op(K.I, 4, 0)),
        GatingTerm(GatingOp.OR, False, op(K.I, 5, 0)),
        GatingTerm(GatingOp.AND, True, op(K.F, 42, 7)),
    )),
    GatingLine(op(K.Q, 17, 2), (GatingTerm(None, False, op(K.I, 5, 0)),)),
)),)


@pytest.mark.parametrize("target", ["Q 17.", "Q = 17."], ids=["plain", "as-in-the-manual"])
def test_gating_example(target: str) -> None:  # 3.5
    assert read(
        "[Gating]\n"
        f"{target}3 = I 4.0 or I 5.0 and not F 42.7\n"
        f"{target}2 = I 5.0\n"
    ) == GATING


def test_set_power_up_parameter() -> None:  # 3.8.2
    assert read(EXAMPLES["set_pp"]) == (ProgramSection((
        Load(op(K.KB, 17)),
        Transfer(op(K.PSEG, 0)),
        Load(op(K.KB, 10)),
        Transfer(op(K.PSEG, 1)),
        CallFB(False, "SetPP"),
    )),)


def test_language_reference_examples_read_clean() -> None:
    """The IL blocks of docs/language.md (fenced without a language) hold no syntax error;
    the ones without a title are [PROGRAM] lines."""
    doc = (ROOT / "docs" / "language.md").read_text(encoding="utf-8")
    # each fenced block, opening fence with its language (a closing fence is no opening)
    fenced = re.findall(r"^```(\w*)\n(.*?)^```\n", doc, re.MULTILINE | re.DOTALL)
    blocks = [body for language, body in fenced if not language]
    assert len(blocks) >= 10
    for block in blocks:
        text = block if block.startswith("[") else "[PROGRAM]\n" + block
        assert parse_text(text)[1] == [], block
