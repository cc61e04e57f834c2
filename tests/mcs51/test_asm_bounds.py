"""Expressions whose values or nesting grow without bound end in a located error, quickly.

Squaring EQU chains once made numbers of millions of bits (the assembler never ended),
and deep nesting exhausted Python's stack (exit 3). Every value is now bounded to 32 bits
and every expression's nesting is bounded; the property test checks random chains
against an independent evaluation with Python integers.
"""

from __future__ import annotations

import random

import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from time_limit import no_hang

from asictl.cli import main
from asictl.diagnostics import DiagnosticError
from asictl.mcs51.asm_expr import MAX_OPERATORS, VALUE_LIMIT
from asictl.mcs51.assembler import assemble_text


def failure(source: str) -> list[tuple[int, str, str]]:
    with no_hang(), pytest.raises(DiagnosticError) as info:
        assemble_text(source, "t.a51")
    return [(d.span.line, d.code, d.message) for d in info.value.diagnostics]


def squaring_chain(lines: int) -> list[str]:
    return ["x0 equ 3"] + [f"x{i} equ x{i - 1}*x{i - 1}" for i in range(1, lines)]


def test_equ_lines_that_square_each_other_stop_at_the_first_value_over_32_bits():
    # 3^(2^5) = 3^32 needs 51 bits: line 6 (x5) is the first too big
    found = failure("\n".join([*squaring_chain(25), "\tdb x24"]) + "\n")
    assert found == [(6, "E512", "value out of range: more than 32 bits")]


def test_squaring_chain_written_in_reverse_order_is_reported_where_it_overflows():
    lines = squaring_chain(25)[::-1]
    found = failure("\n".join([*lines, "\tdb x24"]) + "\n")
    assert found == [(lines.index("x5 equ x4*x4") + 1, "E512",
                      "value out of range: more than 32 bits")]


def test_values_up_to_32_bits_are_still_exact():
    assembly = assemble_text("big equ 0FFFFFFFFh\nneg equ -big\nlo equ big & 0FFh\n")
    values = {s.name: s.value for s in assembly.symbols.values()}
    assert values == {"big": 0xFFFFFFFF, "neg": -0xFFFFFFFF, "lo": 0xFF}


@pytest.mark.parametrize("number", ["100000000h", "4294967296", "9" * 5000, "1" * 33 + "b"])
def test_numbers_over_32_bits_are_an_error_not_a_huge_value(number: str):
    [(line, code, message)] = failure(f"\tdb {number}\n")
    assert (line, code) == (1, "E501")
    assert message.endswith("does not fit in 32 bits") and len(message) < 80


@pytest.mark.parametrize(
    "expression",
    ["(" * 5000 + "1" + ")" * 5000, "-" * 5000 + "1", "+".join(["1"] * 20000),
     "~" * 3000 + "0"],
)
def test_deeply_nested_expressions_are_refused_not_a_stack_overflow(expression: str):
    [(line, code, message)] = failure(f"\tdb {expression}\n")
    assert (line, code) == (1, "E512")
    assert f"more than {MAX_OPERATORS} operators" in message


def test_long_chains_of_forward_definitions_are_refused_not_a_stack_overflow():
    n = 3000
    lines = [f"x{i} equ x{i + 1}+1" for i in range(n)] + [f"x{n} equ 1", "\tdb x0"]
    found = failure("\n".join(lines) + "\n")
    assert found and all(code == "E512" and "nest too deeply" in message
                         for _, code, message in found)
    assert all(1 < line <= n for line, _, _ in found)


def test_an_error_in_a_symbols_definition_is_reported_at_that_definition():
    found = failure("\tdb va\nvb equ 1/0\nva equ vb+1\n")
    assert found == [(2, "E512", "division by zero")]


# ----- property: random chains never hang, and agree with Python's integers --------------

_OPS = ["+", "-", "*", "&", "|", "^"]


@st.composite
def chains(draw: st.DrawFn) -> tuple[list[str], dict[str, int | None]]:
    """EQU lines (in a random order) over symbols s0..sN, each defined only in terms of
    symbols with higher numbers so there is no cycle; and each symbol's expected value
    (None where a value leaves 32 bits)."""
    count = draw(st.integers(1, 30))
    expected: dict[str, int | None] = {}
    lines: list[str] = []
    for i in reversed(range(count)):
        terms = list(range(i + 1, count))

        def term(terms: list[int] = terms) -> tuple[str, int | None]:
            if terms and draw(st.booleans()):
                j = draw(st.sampled_from(terms))
                return f"s{j}", expected[f"s{j}"]
            number = draw(st.integers(0, VALUE_LIMIT - 1))
            return f"{number}", number

        text, value = term()
        for _ in range(draw(st.integers(0, 3))):
            op = draw(st.sampled_from(_OPS))
            right_text, right = term()
            text = f"({text} {op} {right_text})"
            if value is not None and right is not None:
                value = eval(f"value {op} right")  # Python ints: exact, the oracle
                if not -VALUE_LIMIT < value < VALUE_LIMIT:
                    value = None
            else:
                value = None
        expected[f"s{i}"] = value
        lines.append(f"s{i} equ {text}")
    random.Random(draw(st.integers(0, 2**32))).shuffle(lines)
    return lines, expected


@settings(max_examples=200, deadline=None)
@given(chains())
def test_random_expression_chains_assemble_exactly_or_fail_at_a_line(chain):
    lines, expected = chain
    source = "\n".join(lines) + "\n"
    with no_hang():
        try:
            assembly = assemble_text(source, "t.a51")
        except DiagnosticError as exc:
            assert None in expected.values(), exc.diagnostics
            for d in exc.diagnostics:
                assert d.span is not None and 1 <= d.span.line <= len(lines)
                assert d.code == "E512", d
                # the line reported defines a symbol that is indeed out of range
                name = lines[d.span.line - 1].split()[0]
                assert expected[name] is None, (d, lines[d.span.line - 1])
            return
    assert None not in expected.values()
    values = {s.name: s.value for s in assembly.symbols.values()}
    assert values == expected


def test_an_il_program_whose_assembly_squares_itself_fails_compile_at_the_line(tmp_path):
    program = tmp_path / "sq.asi"
    program.write_text("[PROGRAM]\n  A I 1.0\n  = Q 1.0\n[ASSEMBLY]\n"
                       + "\n".join(squaring_chain(25)) + "\n  mov a, #x24\n[END]\n")
    with no_hang():
        result = CliRunner().invoke(main, ["compile", str(program), "-o",
                                           str(tmp_path / "sq.hex")])
    assert result.exit_code == 1, result.output
    # [ASSEMBLY] is line 4, x0 line 5: x5 on line 10
    assert f"{program}:10:1: error: value out of range: more than 32 bits" in result.stderr
