"""``OPERAND=VALUE`` and operand names as every tool reads them (observe.operands): the
IL's own operands, the tools' ``CV n``/``TV n``/``I n``/``Q n``, symbols, and values in
decimal, 0x, 0b and the IL's forms, each checked against what the operand holds."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from asictl.il import ast
from asictl.il.parser import parse_text
from asictl.observe.operands import (
    check_value,
    il_operand,
    parse_assignment,
    parse_operand,
    parse_value,
    plain_operand,
    read_number,
)
from asictl.observe.symbols import SymbolTable

K = ast.OperandKind
W = ast.Width
op = ast.Operand.of


@pytest.mark.parametrize(
    ("text", "node", "maximum"),
    [
        ("I 1.0", op(K.I, 1, 0), 1),
        ("i2 4.3", op(K.I2, 4, 3), 1),
        ("Q17.3", op(K.Q, 17, 3), 1),
        ("F 42.7", op(K.F, 42, 7), 1),
        ("T 3", op(K.T, 3), 1),
        ("C 3", op(K.C, 3), 1),
        ("IB 4", op(K.IB, 4), 255),
        ("QB 16", op(K.QB, 16), 255),
        ("FY 12", op(K.FY, 12), 255),
        ("PSeg 0", op(K.PSEG, 0), 255),
        ("Reading 3", op(K.VAR, 3, name="Reading"), 255),
        ("Reading 3.2", op(K.VAR, 3, 2, name="Reading"), 1),
        ("CV 3", op(K.C, 3, width=W.WORD), 4095),
        ("TV 3", op(K.T, 3, width=W.WORD), 40950),
        ("I 4", op(K.I, 4, width=W.NIBBLE), 15),
        ("I24", op(K.I, 24, width=W.NIBBLE), 15),
        ("I2 4", op(K.I2, 4, width=W.NIBBLE), 15),
        ("q 17", op(K.Q, 17, width=W.NIBBLE), 15),
    ],
)
def test_every_form_is_an_ast_operand(text: str, node: ast.Operand, maximum: int):
    operand = parse_operand(text, {"reading": 4})
    assert operand.node == node
    assert operand.maximum == maximum
    assert parse_operand(str(operand), {"reading": 4}) == operand  # it prints itself back


@pytest.mark.parametrize(
    ("text", "value"),
    [("12", 12), ("0012", 12), ("0x0C", 12), ("0X0c", 12), ("0b1100", 12), ("0Ch", 12),
     ("Ch", 12), ("12d", 12), ("0Bh", 11), ("0b1010_0101", 165), (" 7 ", 7)],
)
def test_numbers(text: str, value: int):
    assert read_number(text) == value


@pytest.mark.parametrize("text", ["", "-1", "x", "0x", "0b2", "1.5", "12h3", "0o17", "1e3"])
def test_what_is_no_number(text: str):
    with pytest.raises(ValueError) as info:
        read_number(text)
    assert str(info.value).endswith("is not a number (such as 11, 0xB, 0Bh or 0b1011)")


def test_an_assignment_and_its_parts():
    assignment = parse_assignment(" FY 12 = 0x55 ")
    assert (assignment.operand.node, assignment.value, assignment.written) == (
        op(K.FY, 12), 0x55, "FY 12")
    motor = SymbolTable("p.symbols.toml", {"motor": ("Motor", "Q 2.0"), "parts": ("Parts", "C 0")})
    assignment = parse_assignment("motor=1", symbols=motor)
    assert (assignment.operand.node, assignment.value, assignment.written) == (
        op(K.Q, 2, 0), 1, "motor")
    assert parse_assignment("CV Parts=4095", symbols=motor).operand.node == op(
        K.C, 0, width=W.WORD)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("I 1.0", "'I 1.0': expected OPERAND=VALUE, such as 'I 1.0=1'"),
        ("=1", "'=1': expected OPERAND=VALUE"),
        ("I 1.0=", "'I 1.0=': expected OPERAND=VALUE"),
        ("I 1.0=2", "'I 1.0': value 2 out of range 0..1 (a bit)"),
        ("Q 17=0x10", "'Q 17': value 16 out of range 0..15 (four data bits)"),
        ("FY 1=256", "'FY 1': value 256 out of range 0..255 (a byte)"),
        ("CV 1=4096", "'CV 1': value 4096 out of range 0..4095 (a count)"),
        ("TV 1=40951", "'TV 1': value 40951 out of range 0..40950 (milliseconds)"),
        ("FY 1=on", "'FY 1': 'on' is not a number"),
        ("I 32.0=1", "'I 32.0': slave 0..31, data bit 0..3"),
        ("I 1.4=1", "'I 1.4': slave 0..31, data bit 0..3"),
        ("I 32=1", "'I 32': slave 0..31"),
        ("F 128.0=1", "'F 128.0': flag byte 0..127, bit 0..7"),
        ("IB 5=1", "'IB 5': an even slave address 0..30"),
        ("PSeg 16=1", "'PSeg 16': PSeg byte 0..15"),
        ("CV 1024=1", "'CV 1024': number 0..1023"),
        ("Reading 4=1", "'Reading 4': 'Reading' has 4 bytes"),
        ("Other 0=1", "'Other 0': 'Other' is not a variable declared by the program"),
        ("KT 500=1", "'KT 500' is not an operand (bits: I, I2, Q, F, T, C, variable bits"),
        ("FW 10=1", "'FW 10' is not an operand"),
    ],
)
def test_each_mistake_names_its_part_and_what_it_may_be(text: str, message: str):
    with pytest.raises(ValueError) as info:
        parse_assignment(text, {"reading": 4})
    assert str(info.value).startswith(message)


def test_a_value_a_file_holds_as_a_number_is_checked_the_same_way():
    byte = parse_operand("QB 16")
    assert check_value(255, byte) == 255
    with pytest.raises(ValueError) as info:
        check_value(256, byte, "x")
    assert str(info.value) == "'x': value 256 out of range 0..255 (a byte)"
    assert parse_value("0FFh", byte) == 255


# what the IL reader takes as a bit or a byte, the tools take too, in range
_bits = st.one_of(
    st.tuples(st.sampled_from(["I", "I2", "Q"]), st.integers(0, 31), st.integers(0, 3)),
    st.tuples(st.just("F"), st.integers(0, 127), st.integers(0, 7)),
)
_bytes = st.one_of(
    st.tuples(st.sampled_from(["IB", "I2B", "QB"]), st.integers(0, 15).map(lambda n: 2 * n)),
    st.tuples(st.just("FY"), st.integers(0, 127)),
    st.tuples(st.just("PSeg"), st.integers(0, 15)),
)
_forms = [str, lambda v: f"0x{v:X}", lambda v: f"0b{v:b}", lambda v: f"0{v:X}h",
          lambda v: f"{v}d"]


@given(_bits | _bytes, st.integers(0, 255), st.sampled_from(_forms))
def test_the_il_readers_operands_read_back_with_any_value_form(parts, value, form):
    text = f"{parts[0]} {parts[1]}" + (f".{parts[2]}" if len(parts) == 3 else "")
    mnemonic = "A" if len(parts) == 3 else "L"
    module, diagnostics = parse_text(f"[PROGRAM]\n{mnemonic} {text}\n")
    assert diagnostics == []
    (statement,) = module.statements()
    value &= 1 if len(parts) == 3 else 0xFF
    assignment = parse_assignment(f"{text}={form(value)}")
    assert assignment.operand.node == statement.operand  # the IL's own operand
    assert assignment.value == value


# the plain forms are read without the IL reader, each exactly as the IL reader reads it
_marks = st.sampled_from([
    "I", "i", "I2", "i2", "Q", "q", "F", "f", "IB", "ib", "I2B", "i2b", "QB", "FY", "fy",
    "PSeg", "PSEG", "pseg", "T", "t", "C", "c", "FW", "KT", "CV", "X", "IX", "I2X", "Reading",
])
_blanks = st.sampled_from(["", " ", "  ", "\t"])
_digits = st.text("0123456789", max_size=6)
_texts = st.builds(
    lambda *parts: "".join(parts), _blanks, _marks, _blanks, _digits,
    st.sampled_from(["", ".", " .", ". ", "..", " "]), _digits,
    st.sampled_from(["", " ", "h", "d", "x", ".1"]),
)


@settings(max_examples=1000)
@given(_texts)
def test_a_plain_form_is_read_as_the_il_reader_reads_it(text: str):
    plain = plain_operand(text)
    if plain is not None:
        assert plain == il_operand(text)
        assert str(plain) == str(il_operand(text))


_timers = st.tuples(st.sampled_from(["T", "C"]), st.integers(0, 1023))


@given(_bits | _bytes | _timers, st.sampled_from(["{} {}", "{}{}", "{}  {}", " {} {} "]))
def test_every_image_operand_as_it_prints_is_a_plain_form(parts, spacing: str):
    """What commands are given most (``force "F 10.0=1"``, a symbol table's operands)
    never waits for the IL reader to load."""
    mark, number = parts[0], f"{parts[1]}" + (f".{parts[2]}" if len(parts) == 3 else "")
    if mark == "I2" and "{}{}" in spacing:
        mark = "I2 "  # glued, I2 4.0 would read as I 24.0
    text = spacing.format(mark, number)
    node = il_operand(text)
    assert node is not None
    assert plain_operand(text) == node
