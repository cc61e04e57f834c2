"""``asictl export --to st``: Structured Text that an independent IEC 61131-3 parser
(blark 0.8.3, in its own venv: .ci/run) reads, with the program's names and lines."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from asictl.build import build_file
from asictl.errors import UserError
from asictl.export.check import BLARK_VARIABLE, blark_parse
from asictl.export.st import export_st
from asictl.observe.symbols import SymbolTable

DEMOS = Path(__file__).parents[2] / "demos"
BLARK = os.environ.get(BLARK_VARIABLE) or shutil.which("blark")
needs_blark = pytest.mark.skipif(
    BLARK is None and not os.environ.get("CI"),  # CI installs it: there it must run
    reason="needs blark 0.8.3 in a venv (.ci/run; ASICTL_BLARK)",
)
#: demos that between them use most kinds of statement: jumps, blocks, firmware calls,
#: counters on the flags, bytes, compares, timers, PARAM (blark takes seconds a file)
COVERING = ["jump.asi", "fb.asi", "counter.asi", "1h_timer.asi", "param.asi"]


def _st(name: str, symbols: SymbolTable | None = None) -> str:
    program = build_file(DEMOS / name).program
    assert program is not None
    return export_st(name, program, symbols).render().replace(f"{DEMOS}/", "")


@needs_blark
@pytest.mark.parametrize("name", COVERING)
def test_blark_parses_the_demos_structured_text(name: str) -> None:
    assert blark_parse(_st(name), BLARK) is None


@needs_blark
@pytest.mark.slow
@pytest.mark.parametrize("path", sorted(DEMOS.glob("*.asi")), ids=lambda p: p.name)
def test_blark_parses_every_demo(path: Path) -> None:
    assert blark_parse(_st(path.name), BLARK) is None


@needs_blark
def test_blark_refusing_the_text_is_reported() -> None:
    complaint = blark_parse("PROGRAM x\nx := ;\nEND_PROGRAM\n", BLARK)
    assert complaint


def test_a_missing_blark_is_a_user_error(tmp_path: Path) -> None:
    with pytest.raises(UserError, match="cannot run"):
        blark_parse("PROGRAM x\nEND_PROGRAM\n", str(tmp_path / "no-blark"))


def test_symbols_name_the_variables_and_il_lines_stand_beside_their_st() -> None:
    text = _st("sequence.asi", SymbolTable("s", {"start": ("Start", "I 1.2")}))
    assert "Start AT %IX0.6 : BOOL;  (* I 1.2 *)" in text
    assert "I1_0 AT %IX0.4 : BOOL;" in text
    assert "(* sequence.asi:15: A I 1.2 *)\nIL_RLO := Start;" in text
    assert "(* sequence.asi:16: A I 1.1 *)\nIL_RLO := IL_RLO AND I1_1;" in text
    assert "IF IL_RLO THEN F0_0 := TRUE; END_IF;" in text


def test_jumps_become_a_case_over_the_pieces_of_the_body() -> None:
    text = _st("jump.asi")
    assert "WHILE IL_PC >= 0 DO" in text
    # JC = manual: the piece that starts at the label, else the next piece
    assert "IF IL_RLO THEN IL_PC := 3; ELSE IL_PC := 1; END_IF;" in text
    assert "    3:\n        (* jump.asi:21: manual: *)" in text


def test_function_blocks_are_function_blocks_with_one_instance_each() -> None:
    text = _st("fb.asi")
    assert "FUNCTION_BLOCK Latch" in text and "FUNCTION_BLOCK Count3" in text
    assert "IL_FB_Latch : Latch;" in text
    assert "IL_FB_Latch();" in text and "IF IL_RLO THEN IL_FB_Count3(); END_IF;" in text
    assert text.count("TODO: finish by hand") == 2
