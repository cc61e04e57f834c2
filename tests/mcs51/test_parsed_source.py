"""Code handed to the assembler parsed already, the first pass alone, and the symbols a
line refers to: what a code generator that builds instructions as objects relies on."""

from __future__ import annotations

import pytest

from asictl.diagnostics import DiagnosticError
from asictl.mcs51.asm_parser import parse_line, referenced_symbols
from asictl.mcs51.assembler import ParsedSource, assemble, locate
from asictl.source import from_string

PROGRAM = """\
        ORG 100h
start:  MOV DPTR,#table
        JC far
        LCALL _SendPrm_ ; _SetPrm_ is only named in a comment
loop:   DJNZ R7,loop
table:  DB 1,2,'ab'
        DS 3
far:    SJMP start
        END
"""
PREDEFINED = {"_SendPrm_": 0x0108}


def parsed(text: str) -> ParsedSource:
    source = from_string("gen", text)
    return ParsedSource(source, [parse_line(line) for line in text.splitlines()])


def test_a_parsed_source_assembles_as_its_text_does():
    from_text = assemble(from_string("gen", PROGRAM), predefined=PREDEFINED)
    from_objects = assemble(parsed(PROGRAM), predefined=PREDEFINED)
    assert from_objects.segments == from_text.segments
    assert from_objects.listing == from_text.listing
    assert from_objects.symbols == from_text.symbols


def test_the_parsed_lines_are_what_is_assembled_not_the_text():
    """The text only labels the listing: the statement comes from the parsed line."""
    source = from_string("gen", "        NOP\n")
    assembly = assemble(ParsedSource(source, [parse_line("        CPL C")]))
    assert assembly.segments == ((0, bytes([0xB3])),)
    assert assembly.listing[0].text == "        NOP"


def test_one_parsed_line_for_each_line_of_text():
    with pytest.raises(ValueError, match="1 parsed lines for 2"):
        assemble(ParsedSource(from_string("gen", "NOP\nNOP\n"), [parse_line("NOP")]))


def test_locate_places_lines_and_labels_as_the_assembly_does():
    layout = locate(from_string("gen", PROGRAM), predefined=PREDEFINED)
    assembly = assemble(from_string("gen", PROGRAM), predefined=PREDEFINED)
    assert layout.addresses == (0x100, 0x100, 0x103, 0x105, 0x108, 0x10A, 0x10E, 0x111, 0x113)
    labels = {name: s.value for name, s in assembly.symbols.items() if s.kind == "label"}
    assert layout.labels == labels
    assert layout.labels["FAR"] == 0x111


def test_locate_reports_nothing_and_leaves_that_to_assemble():
    text = "        JC nowhere\n        NOP\n"
    layout = locate(from_string("gen", text))
    assert layout.addresses == (0, 2)
    with pytest.raises(DiagnosticError, match="undefined symbol 'nowhere'"):
        assemble(from_string("gen", text))


@pytest.mark.parametrize(
    ("line", "names"),
    [
        ("        LCALL _SendPrm_ ; _SetPrm_", ["_SendPrm_"]),
        ("here:   MOV DPTR,#base+HIGH(offset)", ["base", "offset"]),
        ("        MOV C,flags.bit", ["flags", "bit"]),
        ("        DW one,'x',two-$", ["one", "two"]),
        ("size    EQU 2*count", ["count"]),
        ("        DB 'text _SendPrm_'", []),
        ("label:", []),
        ("; LCALL _SendPrm_", []),
    ],
)
def test_the_symbols_a_line_refers_to(line: str, names: list[str]):
    assert list(referenced_symbols(parse_line(line))) == names


def test_a_layout_finishes_into_the_same_assembly_once():
    layout = locate(parsed(PROGRAM), predefined=PREDEFINED)
    assembly = layout.assemble()
    assert assembly == assemble(from_string("gen", PROGRAM), predefined=PREDEFINED)
    with pytest.raises(RuntimeError, match="assembled already"):
        layout.assemble()


def test_a_layout_reports_the_problems_when_it_is_assembled():
    layout = locate(from_string("gen", "        JC nowhere\n"))
    with pytest.raises(DiagnosticError, match="undefined symbol 'nowhere'"):
        layout.assemble()
