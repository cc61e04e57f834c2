"""The server's features without the protocol: hover texts, definitions, references,
completion and the outline, on the demos and on small programs."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.cli import main
from asictl.il.parser import RESERVED, grammar_text
from asictl.lsp import completion, hover, navigation
from asictl.lsp.documents import Documents
from asictl.lsp.texts import INSTRUCTIONS, OPERANDS, OPTIONS, SECTIONS

ROOT = Path(__file__).resolve().parents[2]
DEMOS = ROOT / "demos"


def demo(name: str) -> tuple[Documents, str, list[str]]:
    path = str(DEMOS / name)
    documents = Documents()
    documents.open(path, (DEMOS / name).read_text())
    return documents, path, (DEMOS / name).read_text().split("\n")


def column(lines: list[str], line: int, word: str) -> int:
    return lines[line - 1].index(word) + 1


def test_hover_texts_on_the_fb_demo():
    documents, path, lines = demo("fb.asi")
    analysis = documents.analyse(path)

    def at(line: int, word: str) -> str:
        text = hover.hover(analysis, path, line, column(lines, line, word))
        assert text is not None, (line, word)
        return text

    assert "register := register and operand" in at(26, "A ")
    assert "slave 1, data bit D0 (input)" in at(26, "I 1.0")
    assert "`I a.b`: input: slave a 0..31" in at(26, "I 1.0")  # the operand's mark
    assert "`F y.b`: flag" in at(27, "F 20.0")
    assert "communication memory 214h" in at(27, "F 20.0")
    assert "function block **Latch** in `latch.fb`" in at(31, "Latch")
    assert "firmware block **GetLAS**" in at(44, "GetLAS")
    assert "label **setpp**, line 59; jumps to it from line 56" in at(56, "setpp")
    assert "**[SETUP]**: expected configuration" in at(17, "[SETUP]")
    assert "**auto_start** (default yes)" in at(15, "auto_start")
    assert "the firmware blocks' arguments" in at(45, "PSeg")


def test_hover_names_the_operand_by_the_symbol_table_beside_the_file(tmp_path):
    program = tmp_path / "edge.asi"
    program.write_text("[PROGRAM]\n A I 1.0\n = F 10.0\n = Q 2.0\n")
    (tmp_path / "edge.symbols.toml").write_text('Start = "I1.0"\nEdge = "F 10.0"\n')
    documents = Documents()
    documents.open(str(program), program.read_text())
    analysis = documents.analyse(str(program))
    assert "symbol `Start` (edge.symbols.toml)" in hover.hover(analysis, str(program), 2, 4)
    assert "symbol `Edge`" in hover.hover(analysis, str(program), 3, 4)
    assert "symbol" not in hover.hover(analysis, str(program), 4, 4)
    (tmp_path / "edge.symbols.toml").write_text("Start = 1\n")  # an error: no names
    assert "symbol" not in hover.hover(analysis, str(program), 2, 4)


def test_hover_on_a_variable_and_a_constant():
    documents = Documents()
    documents.open("/v.asi", "[DECL]\nLevel BYTE 2\n[PROGRAM]\n L KT 505\n L Level 1\n")
    analysis = documents.analyse("/v.asi")
    assert "[DECL] line 2: `Level BYTE 2` (2 bytes)" in hover.hover(analysis, "/v.asi", 5, 4)
    assert "505 ms = 51 ticks of 10 ms" in hover.hover(analysis, "/v.asi", 4, 4)


def test_hover_on_l_tells_the_constant_register_from_the_accumulators():
    """``L KT``/``L KC``/``L KP`` leave both accumulators alone; ``L KB`` and ``L FY`` push."""
    documents = Documents()
    text = "[PROGRAM]\n L KT 500\n L KC 3\n L KP 13.9\n L KB 7\n L FY 1\n"
    documents.open("/l.asi", text)
    analysis = documents.analyse("/l.asi")
    texts = [hover.hover(analysis, "/l.asi", line, 2) or "" for line in range(2, 7)]
    for constant in texts[:3]:
        assert "constant register :=" in constant and "ACCU1 and ACCU2 keep" in constant
        assert "ACCU2 := ACCU1" not in constant
    for push in texts[3:]:
        assert "ACCU2 := ACCU1, ACCU1 := operand" in push


def test_definition_and_references_across_files():
    documents, path, lines = demo("fb.asi")
    analysis = documents.analyse(path)
    latch = navigation.definition(analysis, path, 31, column(lines, 31, "Latch"))
    assert [(s.file, s.line) for s in latch] == [(str(DEMOS / "latch.fb"), 1)]
    slave = navigation.definition(analysis, path, 26, column(lines, 26, "I 1.0"))
    assert [s.line for s in slave] == [18]
    uses = navigation.references(analysis, path, 27, column(lines, 27, "F 20.0"))
    assert sorted((Path(s.file).name, s.line) for s in uses) == [("fb.asi", 27), ("latch.fb", 8)]
    without = navigation.references(analysis, path, 59, 1, declarations=False)
    assert [s.line for s in without] == [56]


def test_a_block_file_is_analysed_as_part_of_the_program_beside_it():
    documents = Documents()
    block = str(DEMOS / "latch.fb")
    documents.open(block, (DEMOS / "latch.fb").read_text())
    analysis = documents.analyse(block)
    assert analysis.main == str(DEMOS / "fb.asi")
    # F 20.0 is written by the main program: find references reaches it from the block
    uses = navigation.references(analysis, block, 8, 13)
    assert {Path(s.file).name for s in uses} == {"fb.asi", "latch.fb"}


def labels_at(text: str, line: int, col: int, name: str = "/c.asi") -> list[str]:
    documents = Documents()
    documents.open(name, text)
    items = completion.complete(documents.analyse(name), name, text.split("\n"), line, col)
    return [i.label for i in items]


PROGRAM = ("[OPTIONS]\nauto_start: yes\n\n[SETUP]\n4: iiio, 0\n6: oooo, 0\n[DECL]\n"
           "Level BYTE 2\nBlk FB blk.fb\n[PROGRAM]\ntop: A I 4.0\n    \n")


@pytest.mark.parametrize(("line_text", "expected", "absent"), [
    ("    ", {"A", "AN", "O", "=", "JC", "***"}, {"I"}),
    ("    A ", {"I", "I2", "Q", "F", "T", "C", "Level"}, {"KT"}),
    ("    L ", {"KT", "KB", "FY", "PSeg", "Level"}, {"I"}),
    ("    A I ", {"4.0", "4.1", "4.2"}, {"4.3", "6.0"}),
    ("    = Q ", {"4.3", "6.0", "6.3"}, {"4.0"}),
    ("    JC = ", {"top"}, {"A"}),
    ("    JU FB ", {"Blk", "GetLAS", "SetPP"}, {"top"}),
    ("    CU ", {"C"}, {"I"}),
    ("[", {"[PROGRAM]", "[GATING]", "[DECL]"}, set()),
])
def test_completion_in_program_lines(line_text: str, expected: set[str], absent: set[str]):
    text = PROGRAM.replace("    \n", line_text + "\n")
    found = set(labels_at(text, 12, len(line_text) + 1))
    assert expected <= found, found
    assert not absent & found


def test_completion_of_options_setup_and_declarations():
    assert set(OPTIONS) <= set(labels_at(PROGRAM, 3, 1))
    assert {"yes", "no"} <= set(labels_at("[OPTIONS]\nauto_start: \n", 2, 13))
    assert "iiio" in labels_at("[SETUP]\n5: \n", 2, 4)
    assert {"BYTE", "FB", "TIMER", "COUNTER"} <= set(labels_at("[DECL]\nX \n", 2, 3))
    assert labels_at("[PROGRAM]\n A I 1.0 ; A \n", 2, 14) == []  # in a comment


def test_outline_and_folding_of_the_jump_demo():
    documents, path, _ = demo("jump.asi")
    analysis = documents.analyse(path)
    module = analysis.module(path)
    assert module is not None
    outline = navigation.outline(module, analysis.text(path))
    assert [o.name for o in outline] == ["[SETUP]", "[PROGRAM]"]
    segments = outline[1].children
    assert len(segments) == 5
    assert [c.name for s in segments for c in s.children] == ["manual", "done"]
    assert navigation.folding_ranges(module, analysis.text(path))[0] == (8, 10)


# --------------------------------------------------------------- the texts table


def _docs() -> str:
    text = (ROOT / "docs" / "language.md").read_text()
    return re.sub(r"\s+", " ", re.sub(r"[`|()]", " ", text))


def test_every_operator_and_mark_of_the_grammar_has_a_text():
    grammar = grammar_text()
    operators = {m for m in RESERVED if re.search(rf"^{m}: \"{m}\"i", grammar, re.M)}
    operators -= {"F", "FB", "BYTE", "TIMER", "COUNTER", "AND", "OR", "NOT"}  # not operators
    assert operators <= set(INSTRUCTIONS)
    assert {"=", "+", "-", "!=", "><", ">", ">=", "<", "<=", "***"} <= set(INSTRUCTIONS)
    marks = {m.removesuffix("_MARK") for m in re.findall(r"^(\w+_MARK)\.", grammar, re.M)}
    assert marks == set(OPERANDS)


def test_the_texts_say_what_docs_language_md_says():
    docs = _docs()
    for table in (INSTRUCTIONS, OPERANDS, SECTIONS, OPTIONS):
        for name, entry in table.items():
            for fragment in re.split(r"; |: ", entry.meaning):
                words = re.sub(r"\s+", " ", re.sub(r"[`|()]", " ", fragment)).strip()
                assert words in docs, (name, fragment)


def test_lsp_without_pygls_says_how_to_install_it(monkeypatch: pytest.MonkeyPatch):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "pygls" else real(name, *a))
    result = CliRunner().invoke(main, ["lsp"])
    assert result.exit_code == 2
    assert result.stderr == (
        "asictl: error: the language server needs the 'lsp' extra (no pygls): pip install "
        "'pygls>=2.0,<3' (or, in an asictl checkout, pip install '.[lsp]')\n")


def test_the_command_line_does_not_load_pygls():
    import subprocess
    import sys

    code = ("import sys; from asictl.cli import main\n"
            "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "for name in ('check', 'fmt', 'lsp'):\n"
            "    main.get_command(None, name)\n"
            "assert 'pygls' not in sys.modules, 'pygls loaded'\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            env={"PYTHONPATH": str(ROOT / "src")})
    assert result.returncode == 0, result.stderr
    assert "fmt" in result.stdout and "lsp" in result.stdout
