"""The assembler: source in, exact bytes out; and every kind of error, exactly located."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from asictl.diagnostics import DiagnosticError, Severity
from asictl.errors import UserError
from asictl.mcs51.assembler import assemble, assemble_text
from asictl.source import SourceText, from_string, read_source


def code(source: str, **options) -> bytes:
    """The bytes of a program assembled from address 0 without gaps."""
    assembly = assemble_text(source, **options)
    assert len(assembly.segments) == 1, assembly.segments
    start, data = assembly.segments[0]
    assert start == 0
    return data


def errors(source: str, name: str = "t.a51") -> list[tuple[int, int, str, str]]:
    """(line, column, code, message) of every diagnostic of a source that must fail."""
    with pytest.raises(DiagnosticError) as info:
        assemble_text(source, name)
    return [(d.span.line, d.span.column, d.code, d.message) for d in info.value.diagnostics]


def one_error(source: str) -> tuple[int, int, str, str]:
    found = errors(source)
    assert len(found) == 1, found
    return found[0]


# ----- addressing modes -----


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        ("mov a,#12h", "74 12"),
        ("mov a,30h", "E5 30"),
        ("mov a,@r0", "E6"),
        ("mov a,@R1", "E7"),
        ("mov a,r7", "EF"),
        ("MOV R3,A", "FB"),
        ("mov r0,#-1", "78 FF"),
        ("mov r5,40h", "AD 40"),
        ("mov 40h,r5", "8D 40"),
        ("mov 30h,40h", "85 40 30"),  # source byte first
        ("mov 30h,#7", "75 30 07"),
        ("mov @r1,#7", "77 07"),
        ("mov @r0,30h", "A6 30"),
        ("mov 30h,@r1", "87 30"),
        ("mov dptr,#1234h", "90 12 34"),
        ("mov c,20h.0", "A2 00"),
        ("mov 2Fh.7,c", "92 7F"),
        ("movc a,@a+dptr", "93"),
        ("movc a,@a+pc", "83"),
        ("movc a, @ A + DPTR", "93"),
        ("movc a,@dptr+a", "93"),
        ("movc a,@pc+a", "83"),
        ("movx a,@dptr", "E0"),
        ("movx @dptr,a", "F0"),
        ("movx a,@r1", "E3"),
        ("movx @r0,a", "F2"),
        ("jmp @a+dptr", "73"),
        ("push acc", "C0 E0"),
        ("pop psw", "D0 D0"),
        ("xch a,@r1", "C7"),
        ("xchd a,@r0", "D6"),
        ("anl c,/acc.7", "B0 E7"),
        ("orl c,!20h.1", "A0 01"),
        ("anl c,cy", "82 D7"),
        ("anl 30h,#0Fh", "53 30 0F"),
        ("orl psw,a", "42 D0"),
        ("xrl a,#0FFh", "64 FF"),
        ("inc dptr", "A3"),
        ("mul ab", "A4"),
        ("div AB", "84"),
        ("clr c", "C3"),
        ("clr a", "E4"),
        ("cpl p1.0", "B2 90"),
        ("setb ea", "D2 AF"),
        ("da a", "D4"),
        ("swap a", "C4"),
        ("rlc a", "33"),
        ("nop", "00"),
        ("reti", "32"),
        ("ljmp 1234h", "02 12 34"),
        ("lcall 0FFFFh", "12 FF FF"),
        ("jmp 1234h", "02 12 34"),  # the generic jump is always LJMP
        ("call 1234h", "12 12 34"),  # and the generic call LCALL
        ("ajmp 7FFh", "E1 FF"),
        ("acall 123h", "31 23"),
        ("sjmp $", "80 FE"),
        ("sjmp *", "80 FE"),
        ("jz $+2+127", "60 7F"),
        ("jnc $+2-128", "50 80"),
        ("djnz r7,$", "DF FE"),
        ("djnz 30h,$", "D5 30 FD"),
        ("cjne a,#'x',$", "B4 78 FD"),
        ("cjne a,30h,$+3", "B5 30 00"),
        ("cjne @r1,#0,$", "B7 00 FD"),
        ("cjne r2,#80h,$", "BA 80 FD"),
        ("jb acc.0,$", "20 E0 FD"),
        ("jbc tf0,$", "10 8D FD"),
        ("jnb ri,$", "30 98 FD"),
    ],
)
def test_instruction_encoding(source, expected):
    assert code(f"\t{source}\n").hex(" ").upper() == expected


def test_relative_targets_and_labels():
    source = """\
back:   nop
        sjmp back
        jc fwd
        nop
fwd:    ret
"""
    assert code(source).hex(" ").upper() == "00 80 FD 40 01 00 22"


def test_ajmp_uses_the_page_of_the_next_instruction():
    assembly = assemble_text("\torg 7FEh\n\tajmp 800h\n")
    assert assembly.segments == ((0x7FE, bytes([0x01, 0x00])),)


def test_relative_jump_wraps_around_the_address_space():
    assembly = assemble_text("\torg 0FFFEh\n\tsjmp 0\n")
    assert assembly.segments == ((0xFFFE, bytes([0x80, 0x00])),)


def test_code_may_end_exactly_at_ffff():
    assembly = assemble_text("\torg 0FFFFh\n\tnop\n")
    assert assembly.segments == ((0xFFFF, b"\x00"),)


# ----- directives -----


def test_org_db_dw_ds():
    assembly = assemble_text(
        """\
        org 10h
        db 1, 'AB', "c\\n", -1, 'x'+1
        dw 1234h, -2
        ds 3
        db 0
"""
    )
    assert assembly.segments == (
        (0x10, bytes([1, 0x41, 0x42, 0x63, 0x0A, 0xFF, 0x79, 0x12, 0x34, 0xFF, 0xFE])),
        (0x10 + 11 + 3, b"\x00"),
    )


def test_end_stops_the_file_and_warns_about_text_after_it():
    assembly = assemble_text("\tnop\n\tend\n; comment\n\tnop\n", "t.a51")
    assert assembly.segments == ((0, b"\x00"),)
    [warning] = assembly.diagnostics
    assert (warning.span.line, warning.code, warning.message) == (
        4,
        "W502",
        "text after END is ignored",
    )
    assert warning.severity is Severity.WARNING


def test_symbol_definitions():
    source = """\
count   equ 10
flag    bit 20h.1
var     data 30h
ext     xdata 1234h
table   code 0ABCDh
ivar    idata 80h
        mov a,#count
        setb flag
        mov var,a
        mov dptr,#ext
        mov dptr,#table
        mov r0,#ivar
"""
    assert code(source).hex(" ").upper() == "74 0A D2 01 F5 30 90 12 34 90 AB CD 78 80"
    symbols = assemble_text(source).symbols
    assert (symbols["FLAG"].value, symbols["FLAG"].kind) == (1, "BIT")
    assert (symbols["VAR"].value, symbols["VAR"].kind) == (0x30, "DATA")


def test_set_can_be_redefined_and_applies_from_its_line_on():
    assert code("n set 1\n\tdb n\nn set n+1\n\tdb n\n") == b"\x01\x02"


def test_equ_may_refer_forward_to_labels_and_other_equs():
    source = "a1 equ a2+1\na2 equ later\n\tmov a,#a1\nlater:\tnop\n"
    assert code(source) == bytes([0x74, 0x03, 0x00])


def test_symbols_are_case_insensitive():
    assert code("Loop:\tsjmp LOOP\nVal EQU 5\n\tmov a,#val\n") == bytes([0x80, 0xFE, 0x74, 5])


def test_sfr_may_be_redefined_with_its_own_address():
    assert code("P1 data 90h\n\tmov P1,a\n") == bytes([0xF5, 0x90])


def test_predefined_symbols():
    assert code("\tljmp runtime\n", predefined={"runtime": 0x1234}) == bytes([2, 0x12, 0x34])


def test_predefining_a_reserved_word_is_a_programming_error():
    with pytest.raises(ValueError, match="MOV"):
        assemble_text("", predefined={"MOV": 1})


def test_asm51_controls_are_ignored():
    assert code("$MOD51\n$NOLIST\n\tnop\n") == b"\x00"


# ----- the as31 dialect -----


def test_as31_directives():
    source = """\
        .org 0
        .equ five, 5
        .flag led, P1.3
        .flag bit7, 20h.7
        mov a,#five
        setb led
        clr bit7
        .byte "hi\\t", 1
        .word 0x1234
        .db 2
        .dw 3
        .skip 2
        .BYTE 9
        .end
"""
    assembly = assemble_text(source)
    assert assembly.segments == (
        (0, bytes.fromhex("7405D293C207686909011234020003")),
        (17, b"\x09"),
    )


def test_include_directives(tmp_path):
    (tmp_path / "defs.inc").write_text("limit equ 7\n")
    (tmp_path / "more.inc").write_text("\tdb limit\n")
    main = tmp_path / "main.a51"
    main.write_text("\t.inc defs.inc\n$INCLUDE(more.inc)\n\tmov a,#limit\n")
    assembly = assemble(read_source(main))
    assert assembly.segments == ((0, bytes([7, 0x74, 7])),)
    assert assembly.origin(0).span.file == str(tmp_path / "more.inc")


def test_include_cycle_is_an_error(tmp_path):
    (tmp_path / "a.inc").write_text("\tnop\n\t.inc b.inc\n")
    (tmp_path / "b.inc").write_text("\t.inc a.inc\n")
    main = tmp_path / "main.a51"
    main.write_text("\t.inc a.inc\n")
    with pytest.raises(DiagnosticError) as info:
        assemble(read_source(main))
    [error] = info.value.diagnostics
    assert (Path(error.span.file).name, error.span.line, error.code) == ("b.inc", 1, "E511")
    assert error.message == f"{tmp_path / 'a.inc'} includes itself"


def test_unreadable_include_is_located():
    found = one_error('\tnop\n\t.inc "missing.inc"\n')
    assert found[:3] == (2, 2, "E511")
    assert "missing.inc" in found[3]


def test_include_loader_can_be_replaced():
    files = {"x.inc": "\tdb 42\n"}

    def loader(name: str, including: SourceText) -> SourceText:
        if name not in files:
            raise UserError(f"{name}: no such file")
        return from_string(name, files[name])

    assembly = assemble(from_string("m.a51", "\t.inc x.inc\n"), include=loader)
    assert assembly.segments == ((0, b"\x2a"),)


# ----- numbers and expressions -----


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("10", 10),
        ("010", 10),  # a leading zero is not octal (as31 agrees)
        ("0FFh", 0xFF),
        ("0ffH", 0xFF),
        ("0x1F", 0x1F),
        ("0X1fh", 0x1F),
        ("0bh", 0x0B),
        ("0b101", 5),
        ("101b", 5),
        ("17o", 15),
        ("17q", 15),
        ("99d", 99),
        ("'A'", 0x41),
        ("'\\n'", 0x0A),
        ("'\\''", 0x27),
        ("2+3*4", 14),
        ("(2+3)*4", 20),
        ("100/7", 14),
        ("100%7", 2),
        ("-7/2", -3),
        ("0F0h & 3Ch", 0x30),
        ("0F0h | 0Fh", 0xFF),
        ("0F0h ^ 0FFh", 0x0F),
        ("~0", -1),
        ("1 << 4", 16),
        ("80h >> 3", 16),
        ("2&3|4", 6),
        ("HIGH 1234h", 0x12),
        ("LOW(1234h)", 0x34),
        ("high(1234h)+1", 0x13),
        ("$", 0),
        ("*", 0),
        ("* * 2", 0),
        ("--3", 3),
    ],
)
def test_expression_values(text, value):
    assert code(f"\tdw {text}\n") == (value & 0xFFFF).to_bytes(2, "big")


def test_two_character_constant_is_a_word():
    assert code("\tdw 'AB'\n") == b"AB"


def test_location_counter_is_the_start_of_the_statement():
    assert code("\torg 0\n\tnop\n\tdw $, $+1, *\n")[1:] == bytes([0, 1, 0, 2, 0, 1])


@pytest.mark.parametrize(
    ("operand", "bit"),
    [
        ("20h.0", 0x00),
        ("20h.3", 0x03),
        ("2Fh.7", 0x7F),
        ("ACC.7", 0xE7),
        ("psw.3", 0xD3),
        ("P1.0", 0x90),
        ("B.1", 0xF1),
        ("80h.1", 0x81),
        ("byte.2", 0x0A),
        ("(20h+1).bitno", 0x0B),
    ],
)
def test_bit_addresses(operand, bit):
    assert code(f"byte equ 21h\nbitno equ 3\n\tsetb {operand}\n") == bytes([0xD2, bit])


# ----- listing, symbols and output -----


def test_listing_entries_map_bytes_to_lines():
    source = "; header\nstart:\tmov a,#1\n\tdb 1,2,3,4,5,6\nk equ 3\n"
    assembly = assemble_text(source, "p.a51")
    first, second, third, fourth = assembly.listing
    assert (first.address, first.data, first.cycles) == (None, b"", None)
    assert (second.address, second.data, second.cycles, second.span.line) == (0, b"\x74\x01", 1, 2)
    assert second.text == "start:\tmov a,#1"
    assert (third.address, len(third.data), third.cycles) == (2, 6, None)
    assert fourth.address is None
    assert assembly.origin(1) is second
    assert assembly.origin(7) is third
    assert assembly.origin(8) is None


def test_listing_text():
    assembly = assemble_text("start:\tmov a,#1\n\tdb 1,2,3,4,5,6\n", "p.a51")
    assert assembly.listing_text().splitlines() == [
        "ADDR  CODE         CYC   LINE  SOURCE",
        "; p.a51",
        "0000  74 01          1      1  start:\tmov a,#1",
        "0002  01 02 03 04           2  \tdb 1,2,3,4,5,6",
        "0006  05 06",
    ]


def test_symbol_table_text_lists_only_program_symbols():
    text = assemble_text("start:\tnop\nlimit equ 0ABh\n").symbol_table_text()
    assert text.splitlines() == [
        "NAME   VALUE  KIND",
        "limit   00AB  EQU",
        "start   0000  label",
    ]


def test_hex_has_16_bytes_per_record():
    hex_text = assemble_text("\torg 100h\n\tds 0\n" + "\tnop\n" * 20).to_hex()
    assert hex_text.splitlines() == [
        ":10010000" + "00" * 16 + "EF",
        ":04011000" + "00" * 4 + "EB",
        ":00000001FF",
    ]


def test_several_sources_assemble_as_one_unit_with_their_own_spans():
    first = from_string("a.a51", "start:\tljmp other\n")
    second = from_string("b.a51", "other:\tsjmp start\n")
    assembly = assemble([first, second])
    assert assembly.segments == ((0, bytes([0x02, 0x00, 0x03, 0x80, 0xFB])),)
    assert assembly.origin(3).span.file == "b.a51"
    with pytest.raises(DiagnosticError) as info:
        assemble([from_string("a.a51", "\tnop\n"), from_string("b.a51", "\n\tmov a,#no\n")])
    [diagnostic] = info.value.diagnostics
    assert (diagnostic.span.file, diagnostic.span.line) == ("b.a51", 2)


# ----- errors: one test per kind, with exact place and message -----


def test_unknown_mnemonic():
    assert one_error("\tnop\n\tmvo a,b\n") == (2, 2, "E502", "unknown mnemonic 'mvo'")


def test_unknown_as31_directive():
    assert one_error("\t.text\n") == (1, 2, "E502", "unknown directive '.text'")


def test_wrong_operand_points_at_the_operand():
    assert one_error("\tadd b,a\n") == (
        1,
        6,
        "E503",
        "ADD cannot take 'b' as its first operand here; expected A",
    )
    assert one_error("\tmov a,dptr\n") == (
        1,
        8,
        "E503",
        "MOV cannot take 'dptr' as its second operand here; expected @Ri, Rn, direct, #data",
    )


def test_generic_jump_with_a_wrong_operand_lists_both_forms():
    assert one_error("\tjmp #5\n") == (
        1,
        6,
        "E503",
        "JMP cannot take '#5' as its first operand here; expected @A+DPTR, addr16",
    )
    assert one_error("\tcall @a+dptr\n")[3] == (
        "CALL cannot take '@a+dptr' as its first operand here; expected addr16"
    )


def test_label_on_the_end_line_is_defined():
    assert code("\tsjmp fin\nfin:\tend\n") == bytes([0x80, 0x00])


def test_wrong_operand_count():
    assert one_error("\tnop a\n") == (1, 2, "E503", "NOP takes 0 operands, not 1")
    assert one_error("\tinc\n") == (1, 2, "E503", "INC takes 1 operand, not 0")


def test_relative_jump_out_of_range_says_by_how_much():
    assert one_error("\tsjmp $+2+130\n") == (
        1,
        7,
        "E505",
        "SJMP target 0084h is 3 bytes out of range (offset +130, reach -128..+127)",
    )
    assert one_error("\torg 100h\n\tdjnz r0,$+2-129\n") == (
        2,
        10,
        "E505",
        "DJNZ target 0081h is 1 byte out of range (offset -129, reach -128..+127)",
    )


def test_ajmp_leaving_its_page():
    assert one_error("\torg 7FDh\n\tacall 800h\n") == (
        2,
        8,
        "E506",
        "ACALL target 0800h is outside the 2 KB page 0000h..07FFh; use LCALL",
    )


def test_undefined_symbol():
    assert one_error("\tnop\n\tljmp nowhere\n") == (2, 7, "E507", "undefined symbol 'nowhere'")


def test_duplicate_symbol():
    assert one_error("here:\tnop\nhere:\tnop\n") == (
        2,
        1,
        "E508",
        "symbol 'here' is already defined at t.a51:1:1",
    )


def test_redefining_an_sfr_with_another_value():
    assert one_error("ACC data 12h\n") == (1, 1, "E508", "symbol 'ACC' is predefined as 0E0h")


def test_reserved_word_as_label():
    assert one_error("mov:\tnop\n") == (1, 1, "E501", "'mov' is reserved and cannot name a symbol")


def test_label_survives_an_error_on_its_line():
    # only the bad mnemonic is reported, not also every use of the label
    assert one_error("loop:\tmvo a,b\n\tsjmp loop\n")[:3] == (1, 7, "E502")


def test_not_bit_addressable():
    assert one_error("\tsetb 30h.1\n") == (
        1,
        7,
        "E509",
        "byte 30h is not bit-addressable (20h..2Fh, or an SFR at a multiple of 8)",
    )
    assert one_error("\tclr sp.0\n")[:3] == (1, 6, "E509")


def test_bit_number_out_of_range():
    assert one_error("\tsetb acc.8\n") == (1, 11, "E504", "bit number 8 is not 0..7")


@pytest.mark.parametrize(
    ("source", "column", "message"),
    [
        ("\tmov a,#256", 9, "value 100h is out of range for #data (-128..0FFh)"),
        ("\tmov a,#-129", 9, "value -129 is out of range for #data (-128..0FFh)"),
        ("\tmov 100h,a", 6, "value 100h is out of range for a direct address (0..0FFh)"),
        ("\tmov dptr,#10000h", 12, "value 10000h is out of range for #data16 (-32768..0FFFFh)"),
        ("\tljmp 10000h", 7, "value 10000h is out of range for a code address (0..0FFFFh)"),
        ("\tdb 256", 5, "value 100h is out of range for a byte (-128..0FFh)"),
        ("\tdw 65536", 5, "value 10000h is out of range for a word (-32768..0FFFFh)"),
        ("x bit 100h", 7, "value 100h is out of range for a bit address (0..0FFh)"),
        ("\torg 10000h", 6, "value 10000h is out of range for an address (0..0FFFFh)"),
    ],
)
def test_value_out_of_range(source, column, message):
    assert one_error(source + "\n") == (1, column, "E504", message)


def test_overlapping_code():
    assert one_error("\torg 10h\n\tnop\n\tnop\n\torg 11h\n\tret\n") == (
        5,
        2,
        "E510",
        "code at 0011h overlaps code already placed there by t.a51:3",
    )


def test_code_past_64k():
    assert one_error("\torg 0FFFFh\n\tljmp 0\n")[:3] == (2, 1, "E510")


def test_expression_errors():
    assert one_error("\tdb 1/0\n") == (1, 7, "E512", "division by zero")
    assert one_error("x equ y\ny equ x\n\tdb x\n")[2:] == (
        "E512",
        "symbol 'x' is defined in terms of itself",
    )


def test_precedence_that_as31_reads_differently_needs_parentheses():
    assert one_error("\tdb 2+3&1\n") == (
        1,
        8,
        "E513",
        "add parentheses: as31 and ASM51 group '+' and '&' differently",
    )
    assert one_error("\tdb 2|4&1\n") == (
        1,
        6,
        "E513",
        "add parentheses: as31 and ASM51 group '&' and '|' differently",
    )


def test_org_needs_a_known_value():
    assert one_error("\torg later\nlater:\n") == (
        1,
        6,
        "E514",
        "ORG needs a value known at this point; 'later' is defined later or not at all",
    )


@pytest.mark.parametrize(
    ("line", "column", "message"),
    [
        ("\tdb 'abc", 5, "string has no closing quote"),
        ("\tmov a,#", 9, "expected a value"),
        ("\tmov a,#(1+2", 13, "missing ')'"),
        ("\tmov a,@r2", 8, "invalid indirect operand '@r2'"),
        ("\tdb 1,,2", 7, "missing operand before ','"),
        ("\tmov a,#12x", 9, "malformed number '12x'"),
        ("\tmov a,#a", 9, "register A cannot be used in an expression"),
        ("\tmov a,#1 2", 11, "unexpected '2'"),
        ("\tdb '\\q'", 6, "unknown escape '\\q' in string"),
        ("\tmov a,#'abc'", 9, "a character constant has one or two characters"),
        ("\tdb", 2, "DB needs at least one value"),
        ("\tend now", 6, "unexpected 'now'"),
    ],
)
def test_syntax_errors(line, column, message):
    assert one_error(line + "\n") == (1, column, "E501", message)


def test_all_errors_of_a_file_are_reported_in_order():
    found = errors("\tmvo a\n\tnop\n\tmov a,#300\n\tljmp nowhere\n")
    assert [(line, code) for line, _, code, _ in found] == [(1, "E502"), (3, "E504"), (4, "E507")]


def test_type_mismatch_warnings():
    assembly = assemble_text("\tsetb p1\n\tmov a,tr0\n\tsetb p1.0\n\tmov a,p1\n")
    assert [(d.span.line, d.span.column, d.code) for d in assembly.diagnostics] == [
        (1, 7, "W501"),
        (2, 8, "W501"),
    ]
    assert assembly.diagnostics[0].message == "'p1' is a byte address, used here as a bit address"


# ----- robustness -----

_WORDS = [
    "mov",
    "a",
    "r0",
    "@r1",
    "#",
    "5",
    "0FFh",
    "$",
    "*",
    "x",
    "x:",
    "equ",
    ".org",
    "db",
    "'c'",
    '"s"',
    ",",
    "(",
    ")",
    "+",
    "-",
    "&",
    "|",
    "<<",
    ".",
    "acc",
    "sjmp",
    "ajmp",
    "cjne",
    "end",
    ".inc",
    "set",
    "bit",
    "/",
    "high",
    "10000h",
    "/0",
    ";",
    "\t",
    "@",
]


@settings(max_examples=300, deadline=None)
@given(st.lists(st.lists(st.sampled_from(_WORDS), max_size=8).map(" ".join), max_size=6))
def test_any_input_gives_an_assembly_or_diagnostics(lines):
    try:
        assemble(from_string("fuzz.a51", "\n".join(lines)), include=_no_includes)
    except DiagnosticError as exc:
        assert all(d.span is not None and d.span.line >= 1 for d in exc.diagnostics)


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=60))
def test_any_characters_give_an_assembly_or_diagnostics(text):
    try:
        assemble(from_string("fuzz.a51", text), include=_no_includes)
    except DiagnosticError as exc:
        assert exc.diagnostics


def _no_includes(name: str, including: SourceText) -> SourceText:
    raise UserError(f"{name}: includes are not used here")
