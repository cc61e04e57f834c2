"""Semantic checks: one test per diagnostic class, asserting the exact line and column."""

from __future__ import annotations

from pathlib import Path

import pytest
from manual_examples import EXAMPLES

from asictl.il.checks import Dialect, check_source
from asictl.source import from_string


def diags(text: str, dialect: Dialect = Dialect.CONTROL2, name: str = "t.asi"):
    result = check_source(from_string(name, text), dialect=dialect)
    return [(d.code, d.span.line, d.span.column) for d in result.diagnostics]


def messages(text: str, dialect: Dialect = Dialect.CONTROL2) -> list[str]:
    result = check_source(from_string("t.asi", text), dialect=dialect)
    return [d.message for d in result.diagnostics]


def test_clean_program_has_no_diagnostics():
    src = (
        "[OPTIONS]\nauto_start: yes\n[SETUP]\n31: oooo, 0\n[PROGRAM]\n"
        "    A T 0\n    JC = end\n    N\n    L KT 500\n    S T 0\n***\n"
        "    AN Q 31.0\n    = Q 31.0\nend: BE\n"
    )
    assert diags(src) == []


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("    A I 32.0", "slave address 32 out of range 0..31"),
        ("    A Q 1.4", "data bit 4 out of range 0..3"),
        ("    A F 128.0", "flag byte 128 out of range 0..127"),
        ("    A F 12.8", "flag bit 8 out of range 0..7"),
        ("    A I2 31.9", "data bit 9 out of range 0..3"),
        ("    L FY 128", "flag byte 128 out of range 0..127"),
        ("    L FW 127", "flag word 127 out of range 0..126"),
        ("    L PSeg 16", "PSeg byte 16 out of range 0..15"),
        ("    L QB 32", "QB slave address 32 out of range 0..30"),
        ("    A T 1024", "timer number 1024 out of range 0..1023"),
    ],
)
def test_operand_out_of_range(line: str, message: str):
    src = f"[PROGRAM]\n    A I 1.0\n{line}\n"
    result = check_source(from_string("t.asi", src))
    errors = [d for d in result.diagnostics if d.code == "E201"]
    assert [(d.span.line, d.span.column, d.message) for d in errors] == [(3, 7, message)]


@pytest.mark.parametrize(
    ("const", "message"),
    [
        ("KT 40960", "KT 40960 out of range 0..40950"),
        ("KC 4096", "KC 4096 out of range 0..4095"),
        ("KB 256", "KB 256 out of range 0..255"),
        ("KW 65536", "KW 65536 out of range 0..65535"),
        ("KP 32.1", "KP slave address 32 out of range 0..31"),
        ("KP 3.16", "KP parameter 16 out of range 0..15"),
    ],
)
def test_constant_out_of_range(const: str, message: str):
    src = f"[PROGRAM]\n    L {const}\n"
    assert [(d.code, d.span.line, d.span.column, d.message)
            for d in check_source(from_string("t.asi", src)).diagnostics] == [
        ("E201", 2, 7, message)
    ]


@pytest.mark.parametrize("area", ["IB", "QB", "I2B"])
def test_odd_byte_address(area: str):
    src = f"[PROGRAM]\n    L {area} 5\n"
    assert diags(src) == [("E202", 2, 7)]
    assert f"{area} takes an even slave address" in messages(src)[0]


def test_undeclared_timer_and_counter_above_14():
    src = "[PROGRAM]\n    A T 15\n    = Q 1.0\n***\n    A C 200\n    = Q 1.1\n"
    assert diags(src) == [("E203", 2, 7), ("E203", 5, 7)]


def test_declared_timer_and_counter_are_accepted():
    src = (
        "[DECL]\nT134 TIMER\nC27 COUNTER\n[PROGRAM]\n    A T 134\n    S C 27\n***\n"
        "    A C 27\n    S T 134\n"
    )
    assert diags(src) == []


def test_declaring_a_builtin_timer_warns():
    assert diags("[DECL]\nT3 TIMER\n") == [("W204", 2, 1)]


def test_kt_not_a_multiple_of_10_warns_and_names_the_rounded_value():
    src = "[PROGRAM]\n    L KT 505\n"
    assert diags(src) == [("W202", 2, 7)]
    assert "rounded up to 510 ms" in messages(src)[0]


def test_duplicate_label_and_undefined_jump():
    src = "[PROGRAM]\nx:  A I 1.0\n    JC = nowhere\nX:  BE\n"
    assert diags(src) == [("E206", 3, 5), ("E205", 4, 1)]


def test_labels_are_scoped_per_block(tmp_path: Path):
    (tmp_path / "blk.fb").write_text("[PROGRAM]\n    JU = top\n")
    main = tmp_path / "main.asi"
    main.write_text("[DECL]\nBlk FB blk.fb\n[PROGRAM]\ntop: A I 1.0\n    JC FB Blk\n")
    from asictl.source import read_source

    result = check_source(read_source(main))
    assert [(d.code, Path(d.span.file).name, d.span.line) for d in result.diagnostics] == [
        ("E206", "blk.fb", 2)
    ]


def test_undeclared_function_block():
    src = "[PROGRAM]\n    JU FB Mean\n"
    assert diags(src) == [("E207", 2, 5)]


def test_firmware_blocks_need_no_declaration():
    src = "[PROGRAM]\n    L KB 17\n    T PSeg 0\n    JU FB SetPP\n"
    assert diags(src) == []


def test_function_block_file_missing(tmp_path: Path):
    main = tmp_path / "main.asi"
    main.write_text("[DECL]\nMean FB mean.fb\n[PROGRAM]\n    JU FB Mean\n")
    from asictl.source import read_source

    result = check_source(read_source(main))
    assert [(d.code, d.span.line, d.span.column) for d in result.diagnostics] == [("E208", 2, 1)]


def test_function_block_file_found_case_insensitively_and_in_lib(tmp_path: Path):
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "mean.fb").write_text("[PROGRAM]\n    A I 1.0\n    = Q 2.0\n")
    main = tmp_path / "main.asi"
    main.write_text("[DECL]\nMean FB MEAN.FB\n[PROGRAM]\n    JU FB Mean\n")
    from asictl.source import read_source

    assert check_source(read_source(main), lib=[lib]).diagnostics == []


def test_recursion_is_an_error(tmp_path: Path):
    (tmp_path / "a.fb").write_text("[PROGRAM]\n    JU FB Beta\n")
    (tmp_path / "b.fb").write_text("[PROGRAM]\n    JU FB Alpha\n")
    main = tmp_path / "main.asi"
    main.write_text("[DECL]\nAlpha FB a.fb\nBeta FB b.fb\n[PROGRAM]\n    JU FB Alpha\n")
    from asictl.source import read_source

    result = check_source(read_source(main))
    found = [(d.code, Path(d.span.file).name, d.span.line, d.message) for d in result.diagnostics]
    assert found == [("E209", "b.fb", 2, "recursive function block call: Alpha -> Beta -> Alpha")]


def test_duplicate_slave_addresses_across_setup_sections():
    src = "[SETUP]\n16: iiio, 1\n[SETUP]\n16: 8h, 0\n"
    assert diags(src) == [("E210", 4, 1)]


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("0: 8h, 0", "slave address 0 out of range 1..31"),
        ("32: 8h, 0", "slave address 32 out of range 1..31"),
        ("3: 10h, 0", "I/O code 16 out of range 0..F"),
        ("3: 8h, 10h", "ID code 16 out of range 0..F"),
        ("3: 8h, 0, 10h", "parameter 16 out of range 0..F"),
    ],
)
def test_setup_ranges(line: str, message: str):
    result = check_source(from_string("t.asi", f"[SETUP]\n{line}\n"))
    assert [(d.code, d.span.line, d.span.column) for d in result.diagnostics] == [("E211", 2, 1)]
    assert message in result.diagnostics[0].message


def test_unknown_and_repeated_options():
    src = "[OPTIONS]\nauto_strat: yes\nmap_counters: on\nmap_counters: off\n"
    assert diags(src) == [("E212", 2, 1), ("W203", 4, 1)]


def test_first_check_lint_after_assignment():
    src = "[PROGRAM]\n    A I 1.0\n    = Q 1.0\n    A I 2.0\n    = Q 2.0\n"
    assert diags(src) == [("W201", 4, 5)]


def test_no_lint_after_segment_end():
    src = "[PROGRAM]\n    A I 1.0\n    = Q 1.0\n***\n    A I 2.0\n    = Q 2.0\n"
    assert diags(src) == []


@pytest.mark.parametrize(
    "first",
    ["= Q 1.0", "S F 1.0", "R F 1.0", "N", "JC = x", "BEC", "PARAM", "CU C 1", "JC FB GetId"],
)
def test_register_read_while_always_undefined(first: str):
    src = f"[PROGRAM]\n    {first}\nx:  A I 1.0\n    = Q 2.0\n"
    assert diags(src)[0] == ("E213", 2, 5)


def test_register_defined_on_some_path_is_accepted():
    # 'x' is reached with the register undefined by falling through from ***, but defined
    # when jumped to from below: no error.
    src = "[PROGRAM]\n    A I 1.0\n***\nx:  = Q 1.0\n    A I 2.0\n    JC = x\n"
    assert [d for d in diags(src) if d[0] == "E213"] == []


def test_register_undefined_after_segment_end():
    src = "[PROGRAM]\n    A I 1.0\n    = Q 1.0\n***\n    = Q 2.0\n"
    assert diags(src) == [("E213", 5, 5)]


def test_undeclared_variable_and_offset_range():
    src = "[DECL]\nReading BYTE 5\n[PROGRAM]\n    L Reading 5\n    T Other 0\n    A Reading 4.7\n"
    assert diags(src) == [("E201", 4, 7), ("E214", 5, 7)]


def test_duplicate_declarations_and_firmware_name():
    src = "[DECL]\nX BYTE 1\nx BYTE 2\nSetPP BYTE 1\n"
    assert diags(src) == [("E215", 3, 1), ("E215", 4, 1)]


def test_options_in_function_block_file(tmp_path: Path):
    (tmp_path / "b.fb").write_text("[OPTIONS]\nauto_start: no\n[PROGRAM]\n    BE\n")
    main = tmp_path / "main.asi"
    main.write_text("[DECL]\nBeta FB b.fb\n[PROGRAM]\n    JU FB Beta\n")
    from asictl.source import read_source

    result = check_source(read_source(main))
    assert [(d.code, Path(d.span.file).name, d.span.line) for d in result.diagnostics] == [
        ("E217", "b.fb", 1)
    ]


def test_assigning_timer_status_is_refused():
    src = "[PROGRAM]\n    A I 1.0\n    = T 3\n"
    assert diags(src) == [("E218", 3, 7)]


def test_control1_dialect_reports_control2_features():
    src = (
        "[DECL]\nV BYTE 1\n[PROGRAM]\n    L KB 3\n    T FY 1\n    A T 20\n    BEU\n"
        "    L T 3\n    T C 4\n    L KT 100\n"
    )
    found = diags(src, Dialect.CONTROL1)
    assert ("E216", 1, 1) in found  # [DECL]
    assert ("E216", 4, 5) in found  # L KB
    assert ("E216", 5, 5) in found  # T FY
    assert ("E216", 6, 7) in found  # timer 20
    assert ("E216", 7, 5) in found  # BEU
    # word moves of timers/counters and KT exist in Control I
    assert not [d for d in found if d[1] in (8, 9, 10)]


def test_control2_dialect_accepts_the_same_program_features():
    src = "[PROGRAM]\n    L KB 3\n    T FY 1\n    BEU\n"
    assert diags(src) == []


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_manual_examples_check_clean(name: str, tmp_path: Path):
    # the declaration example names a block file; give it one so the check is complete
    (tmp_path / "MEAN.FB").write_text("[PROGRAM]\n    L Reading 0\n    T FY 0\n")
    path = tmp_path / f"{name}.asi"
    path.write_text(EXAMPLES[name] + "[PROGRAM]\n    JU FB MEAN_VALUE\n"
                    if name == "declaration" else EXAMPLES[name])
    from asictl.source import read_source

    assert check_source(read_source(path)).diagnostics == []


def test_variable_named_like_an_operand_is_refused():
    src = "[DECL]\nI4x BYTE 1\nFY2 BYTE 1\nOk BYTE 1\nDPTR BYTE 1\nMovx BYTE 1\n"
    assert diags(src) == [("E219", 2, 1), ("E219", 3, 1), ("E219", 5, 1), ("E219", 6, 1)]
    assert "reads as 'I 4'" in messages(src)[0]
