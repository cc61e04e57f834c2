"""The analyses of a checked program: wiring (W70x), logic (W71x), directives (W721)."""

from __future__ import annotations

from pathlib import Path

import pytest
from manual_examples import EXAMPLES

from asictl.diagnostics import Diagnostic
from asictl.il.checks import check_source
from asictl.source import from_string, read_source

ROOT = Path(__file__).resolve().parents[2]
SETUP = "[SETUP]\n1: iiii, 0\n2: oooo, 0\n5: iiib, 0\n"


def check(text: str, name: str = "t.asi") -> list[Diagnostic]:
    return check_source(from_string(name, text)).diagnostics


def found(text: str) -> list[tuple[str, int]]:
    return [(d.code, d.span.line) for d in check(text) if d.span]


def only(text: str, code: str) -> Diagnostic:
    matching = [d for d in check(text) if d.code == code]
    assert len(matching) == 1, check(text)
    return matching[0]


def program(*lines: str, setup: str = SETUP) -> str:
    """A whole program: the setup, then [PROGRAM] from line 6 on."""
    assert setup.count("\n") == 4
    return setup + "[PROGRAM]\n" + "".join(f"{line}\n" for line in lines)


CLEAN = program(
    "    A I 1.0", "    = Q 2.0", "***",
    "    L KT 500", "    A I 1.1", "    S T 3", "***",
    "    A T 3", "    = Q 2.1", "***",
    "    A I 5.0", "    AN I 5.3", "    = Q 5.3", "***",
)


def test_a_clean_program_reports_nothing():
    assert check(CLEAN) == []


# ------------------------------------------------------------------------ wiring


def test_reading_an_output_bit_names_the_operand_the_slave_and_its_setup_line():
    d = only(program("    A I 2.0", "    = Q 2.0"), "W701")
    assert d.span.line == 6 and d.span.column == 7
    assert "I 2.0" in d.message and "slave 2" in d.message and "output" in d.message
    assert [(span.line, text) for span, text in d.related] == [
        (3, "slave 2 is set up here as oooo (8h)")]


def test_writing_an_input_bit_and_reading_it_back():
    diagnostics = [d for d in check(program("    A I 1.0", "    = Q 1.0", "    A Q 1.1"))
                   if d.code == "W701"]
    assert [(d.span.line, d.related[0][0].line) for d in diagnostics] == [(7, 2), (8, 2)]
    assert "Q 1.0" in diagnostics[0].message and "input" in diagnostics[0].message


def test_direction_per_data_bit_and_bidirectional_both_ways():
    # slave 5 is iiib: D0..D2 inputs, D3 both
    text = program("    A I 5.1", "    A I 5.3", "    = Q 5.3", "    = Q 5.2", "    = Q 5.0")
    assert [(d.code, d.span.line) for d in check(text) if d.code == "W701"] == [
        ("W701", 9), ("W701", 10)]


def test_numeric_and_tristate_io_codes():
    setup = "[SETUP]\n1: 0, 0\n2: 8h, 0\n3: Fh, 0\n"
    text = program("    A I 1.0", "    = Q 2.0", "***", "    A I 3.0", "    = Q 3.1",
                   setup=setup)
    assert found(text) == [("W701", 9), ("W701", 10)]
    assert "tristate" in only(text.replace("    = Q 3.1\n", ""), "W701").message


def test_byte_operands_warn_only_when_no_bit_fits():
    text = program("    L IB 2", "    T QB 4", "    L IB 0", "    T QB 0")
    # IB 2: slaves 2 (oooo) and 3 (none): no input bit; QB 4: slaves 4, 5: 5's D3 is both;
    # IB 0: slave 1 has inputs; QB 0: slave 1 iiii, slave 0 never: no output bit
    assert [(d.code, d.span.line) for d in check(text) if d.code.startswith("W70")] == [
        ("W701", 6), ("W701", 9)]


def test_slave_not_in_setup():
    d = only(program("    A I 1.0", "    = Q 7.3"), "W702")
    assert (d.span.line, d.span.column) == (7, 7)
    assert "Q 7.3" in d.message and "slave 7" in d.message and "configuration" in d.message
    assert d.related[0][0].line == 1 and "1, 2, 5" in d.related[0][1]


def test_slave_not_in_setup_with_ignore_config_errors_and_bytes():
    text = "[OPTIONS]\nignore_config_errors: yes\n" + program(
        "    L IB 8", "    T FY 1", setup="[SETUP]\n1: iiii, 0\n2: oooo, 0\n\n")
    d = only(text, "W702")
    assert "slaves 8 and 9" in d.message and "keeps the program running" in d.message


@pytest.mark.parametrize(
    ("head", "line"),
    [("[SETUP]\n; nothing yet\n", 1), ("[OPTIONS]\nauto_start: yes\n", 3)],
    ids=["empty-setup", "options-without-setup"],
)
def test_no_slave_in_setup(head: str, line: int):
    d = only(head + "[PROGRAM]\n    A I 1.0\n    = Q 2.0\n", "W703")
    assert d.span.line == line and "never runs" in d.message
    assert [x.code for x in check(head + "[PROGRAM]\n    A I 1.0\n    = Q 2.0\n")] == ["W703"]


def test_no_slave_with_ignore_config_errors_says_what_happens_instead():
    text = "[OPTIONS]\nignore_config_errors: yes\n[PROGRAM]\n    A I 1.0\n    = Q 2.0\n"
    assert "no slave" in only(text, "W703").message


def test_param_and_firmware_blocks_for_a_slave_not_in_setup():
    text = program(
        "    A I 1.0", "    L KP 9.3", "    PARAM", "***",
        "    L KB 17", "    T PSeg 0", "    L KB 10", "    T PSeg 1", "    JU FB SetPP",
        "    L KB 2", "    T PSeg 0", "    JU FB SendPrm",
        "    L KB 9", "    T PSeg 0", "    JU FB GetLAS",
    )
    diagnostics = [d for d in check(text) if d.code == "W704"]
    assert [(d.span.line, d.related[0][0].line) for d in diagnostics] == [(8, 7), (14, 10)]
    assert "slave 9" in diagnostics[0].message and "PARAM" in diagnostics[0].message
    assert "SetPP" in diagnostics[1].message and "slave 17" in diagnostics[1].message


def test_a_label_forgets_which_slave_a_constant_named():
    text = program("    A I 1.0", "    L KP 9.3", "x:  PARAM", "    JC = x")
    assert not [d for d in check(text) if d.code == "W704"]


# ---------------------------------------------------------------------------- logic


def test_assigned_twice_names_both_lines():
    text = program("    A I 1.0", "    = Q 2.0", "***", "    A I 1.1", "    = Q 2.0")
    d = only(text, "W711")
    assert d.span.line == 10 and "Q 2.0" in d.message and "line 7" in d.message
    assert [span.line for span, _ in d.related] == [7]


def test_assignments_on_exclusive_paths_are_fine_as_in_the_jump_demo():
    text = program(
        "    A I 1.0", "    JC = manual", "***",
        "    A I 1.1", "    = Q 2.0", "    JU = done", "***",
        "manual: A I 1.2", "    = Q 2.0", "***",
        "done: A I 1.3", "    = Q 2.1",
    )
    assert check(text) == []


def test_a_loop_runs_one_assignment_after_the_other():
    text = program("again: A I 1.0", "    = Q 2.1", "    A F 1.0", "    JC = again",
                   "    A I 1.1", "    = F 1.0", "    = Q 2.1")
    assert only(text, "W711").span.line == 12


def test_gating_lines_and_set_reset_latches():
    text = SETUP + "[GATING]\nQ 2.0 = I 1.0\n[PROGRAM]\n    A I 1.1\n    S Q 2.0\n" \
        "    A I 1.2\n    R Q 2.0\n***\n    A I 1.3\n    = Q 2.0\n"
    d = only(text, "W711")
    assert d.span.line == 14 and d.related[0][0].line == 6


def test_an_assignment_in_a_called_block_counts_at_the_call(tmp_path: Path):
    (tmp_path / "blk.fb").write_text("[PROGRAM]\n    A I 1.0\n    = Q 2.0\n")
    main = tmp_path / "main.asi"
    main.write_text(
        SETUP + "[DECL]\nBlk FB blk.fb\n[PROGRAM]\n    A I 1.1\n    = Q 2.0\n"
        "    JU FB Blk\n    JU FB Blk\n"
    )
    diagnostics = [d for d in check_source(read_source(main)).diagnostics]
    assert [(d.code, Path(d.span.file).name, d.span.line) for d in diagnostics] == [
        ("W711", "blk.fb", 3)]
    notes = diagnostics[0].related
    assert [(Path(s.file).name, s.line) for s, _ in notes] == [("main.asi", 9), ("main.asi", 10)]


def test_timer_set_but_never_read_and_read_but_never_set():
    text = program("    L KT 500", "    A I 1.0", "    S T 3", "***", "    A T 4", "    = Q 2.0")
    assert found(text) == [("W712", 8), ("W713", 10)]
    assert "timer 3" in only(text, "W712").message
    assert "timer 4" in only(text, "W713").message


def test_counters_and_map_counters():
    text = program("    A I 1.0", "    CU C 2", "    A C 3", "    = Q 2.0")
    assert found(text) == [("W712", 7), ("W713", 8)]
    mapped = "[OPTIONS]\nmap_counters: yes\n" + text
    assert [c for c, _ in found(mapped)] == []  # the host reads and writes C 0..14
    declared = program("    A I 1.0", "    CU C 20", setup="[SETUP]\n1: iiii, 0\n\n\n") \
        .replace("[PROGRAM]", "[DECL]\nC20 COUNTER\n[PROGRAM]")
    assert "counter 20" in only("[OPTIONS]\nmap_counters: yes\n" + declared, "W712").message


def test_reset_alone_does_not_start_a_timer():
    assert found(program("    A I 1.0", "    R T 2", "***", "    A T 2", "    = Q 2.0")) == [
        ("W713", 9)]


def test_flag_read_but_never_written():
    d = only(program("    A F 10.0", "    = Q 2.0"), "W714")
    assert d.span.line == 6 and "F 10.0" in d.message and "asictl: host F 10.0" in d.message


@pytest.mark.parametrize(
    "writer",
    ["    A I 1.0\n    = F 10.0", "    L KB 1\n    T FY 10", "    L KW 1\n    T FW 9",
     "    A I 1.0\n    S F 10.0"],
    ids=["bit", "byte", "word-low-byte", "set"],
)
def test_a_flag_written_by_bit_byte_or_word_is_written(writer: str):
    assert check(program(writer, "***", "    A F 10.0", "    = Q 2.0")) == []


def test_flag_bytes_and_words_count_any_bit_written():
    assert found(program("    A I 1.0", "    = F 11.3", "    L FY 11", "    T FY 12",
                         "    L FW 20", "    T FY 13")) == [("W714", 10)]


def test_param_writes_f127_and_map_counters_the_counter_flags():
    assert check(program("    A F 127.7", "    = Q 2.0", "***",
                         "    A I 1.0", "    L KP 5.3", "    PARAM")) == []
    mapped = "[OPTIONS]\nmap_counters: yes\n" + program("    L FY 96", "    T FY 1")
    assert [c for c, _ in found(mapped)] == []


def test_assembler_code_may_write_anything():
    assert check(program("    ASM mov 20h,#1", "    A F 10.0", "    = Q 2.0")) == []


def test_unreachable_code_after_beu_and_ju_reported_once_per_run():
    text = program("    A I 1.0", "    = Q 2.0", "    BEU", "    A I 1.1", "    = Q 2.1",
                   "***", "end: BE", "    JU = end", "***", "    L KB 1")
    d = only(text, "W715")
    assert d.span.line == 9 and "BEU" in d.message and "line 8" in d.message
    jumped = program("    A I 1.0", "    JU = x", "    = Q 2.0", "x:  = Q 2.1")
    assert only(jumped, "W715").span.line == 8


def test_code_after_a_conditional_end_or_jump_is_reachable():
    """Not W715; but after a BEC that did not end the cycle the register is 0 (W205)."""
    assert found(program("    A I 1.0", "    BEC", "    JC = x", "    = Q 2.0",
                         "x:  = Q 2.1")) == [("W205", 9)]


def test_label_never_jumped_to_and_block_never_called(tmp_path: Path):
    text = program("    A I 1.0", "here: = Q 2.0")
    d = only(text, "W716")
    assert d.span.line == 7 and "here" in d.message
    decl = program("    A I 1.0", "    = Q 2.0").replace("[PROGRAM]", "[DECL]\nMean FB mean.fb\n"
                                                      "[PROGRAM]")
    d = only(decl, "W717")
    assert d.span.line == 6 and "Mean" in d.message


# ------------------------------------------------------ fragments, errors, examples


def test_a_fragment_is_not_held_against_its_wiring_or_its_flags():
    text = "[PROGRAM]\n    A F 1.0\n    A I 9.0\n    = Q 7.3\n    L KP 9.1\n    PARAM\n"
    assert check(text) == []


def test_a_fragment_still_gets_the_logic_warnings():
    text = "[PROGRAM]\n    A I 1.0\n    = Q 2.0\n    = Q 2.0\n"
    assert [c for c, _ in found(text)] == ["W711"]


def test_a_program_with_errors_is_not_analysed():
    text = program("    A I 1.0", "    = Q 7.3", "***", "    A I 32.0")
    assert [c for c, _ in found(text)] == ["E201"]


@pytest.mark.parametrize("path", sorted((ROOT / "demos").glob("*.asi")), ids=lambda p: p.name)
def test_no_demo_gets_a_warning(path: Path):
    assert check_source(read_source(path)).diagnostics == []


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_no_manual_example_gets_a_warning(name: str):
    assert check(EXAMPLES[name]) == []


# ----------------------------------------------------------------------- directives


def test_ignore_on_the_line_for_the_next_line_and_for_the_file():
    base = ["    A F 10.0", "    = Q 2.0", "***", "    A F 11.0", "    = Q 2.1"]
    assert found(program(*base)) == [("W714", 6), ("W714", 9)]
    same_line = base.copy()
    same_line[0] += "      ; asictl: ignore W714 set by the panel"
    assert found(program(*same_line)) == [("W714", 9)]
    next_line = ["; asictl: ignore W714", *base]
    assert found(program(*next_line)) == [("W714", 10)]
    whole_file = [*base, "; asictl: ignore-file W714"]
    assert found(program(*whole_file)) == []
    other_code = base.copy()
    other_code[0] += " ; asictl: ignore W711"
    assert found(program(*other_code)) == [("W714", 6), ("W714", 9)]


def test_ignore_without_codes_silences_every_warning_but_no_error():
    text = program("    A F 10.0 ; asictl: ignore", "    = Q 7.0 ; asictl: ignore",
                   "    A I 40.0 ; asictl: ignore")
    assert found(text) == [("E201", 8)]


def test_host_flags_declared_by_directive():
    text = program("; asictl: host F 10.0, FY 11 FW 12  (the HMI writes these)",
                   "    A F 10.0", "    A F 11.5", "    A F 13.0", "    = Q 2.0")
    assert check(text) == []


def test_a_semicolon_in_code_cannot_start_a_directive_early():
    text = program("    A F 10.0", "    = Q 2.0 ; see F 10.0 ; asictl: ignore W714")
    assert found(text) == [("W714", 6)]


@pytest.mark.parametrize(
    ("comment", "message"),
    [
        ("; asictl: ignor W714", "did you mean 'ignore'"),
        ("; asictl: ignore W799", "'W799' is no asictl code"),
        ("; asictl: ignore E201", "errors cannot be ignored"),
        ("; asictl: host", "needs the flags"),
        ("; asictl: host F 200.0", "is no flag"),
    ],
)
def test_malformed_directives(comment: str, message: str):
    d = only(program("    A I 1.0", "    = Q 2.0", comment), "W721")
    assert d.span.line == 8 and message in d.message


# ------------------------------------------------------------------------ cascades


def test_no_register_error_after_a_skipped_first_line_of_a_segment():
    text = "[PROGRAM]\n    A I 1.0\n    = Q 1.0\n***\n    A I 1.0 2\n    = Q 2.0\n***\n" \
        "    X Y\n    = Q 2.1\n"
    assert [(d.code, d.span.line) for d in check(text)] == [("E103", 5), ("E104", 8)]


def test_a_skipped_line_does_not_hide_a_real_register_error_elsewhere():
    text = "[PROGRAM]\n    A I 1.0 2\n    = Q 2.0\n***\n    = Q 2.1\n"
    assert [(d.code, d.span.line) for d in check(text)] == [("E103", 2), ("E213", 5)]


def test_no_unknown_label_error_for_a_label_lost_with_its_line():
    text = "[PROGRAM]\nloop A I 1.0\n    JC = loop\nx:  A Z%\n    JC = x\n    JC = nowhere\n"
    assert [(d.code, d.span.line) for d in check(text)] == [
        ("E104", 2), ("E102", 4), ("E206", 6)]
    assert "a label is written 'loop:'" in check(text)[0].message


def test_german_and_misspelt_names_in_the_semantic_checks():
    text = "[OPTIONS]\nautostart: yes\n[DECL]\nReading BYTE 2\n[PROGRAM]\n    A E 1.0\n" \
        "    L Readin 1\n    JU FB GetLDZ\n    JC = nowher\nnowhere: BE\n"
    messages = [d.message for d in check(text)]
    assert "did you mean 'auto_start'?" in messages[0]
    assert "STEP 5's German 'E' is 'I' here" in messages[1]
    assert "did you mean 'Reading'?" in messages[2]
    assert "did you mean 'GetLDS'?" in messages[3]
    assert "did you mean 'nowhere'?" in messages[4]
