"""The output stream: instruction objects in, bytes, lines and references out.

The relaxation is checked at the exact reach of a short jump (+127 and -128 bytes from
the end of the ``JC``) and where growing one jump pushes another out of reach; the
peephole rules on objects; the references a program's firmware entry points are read
from; and that the code generator finds nothing again in text (no regular expressions).
"""

from __future__ import annotations

import ast as python_ast
from pathlib import Path

import pytest

from asictl.build import check
from asictl.codegen8051.compiler import compile_program
from asictl.codegen8051.stream import (
    DPTR,
    GENERATED,
    A,
    Bit,
    C,
    End,
    Imm,
    Insn,
    Mark,
    Org,
    OutputStream,
    Raw,
    Ref,
)
from asictl.diagnostics import DiagnosticError
from asictl.source import from_string

PACKAGE = Path(__file__).resolve().parents[2] / "src" / "asictl" / "codegen8051"
JC, JNC, LJMP = 0x40, 0x50, 0x02


def nops(out: OutputStream, count: int) -> None:
    for _ in range(count):
        out.emit(Insn("NOP"))


def code(out: OutputStream) -> bytes:
    out.add(End())
    assembly = compile_stream(out).assembly
    assert len(assembly.segments) == 1
    return assembly.segments[0][1]


def compile_stream(out: OutputStream):  # type: ignore[no-untyped-def]
    return out.assemble({})


@pytest.mark.parametrize(("skipped", "long"), [(127, False), (128, True)])
def test_a_forward_branch_grows_exactly_when_its_target_is_out_of_reach(skipped, long):
    out = OutputStream()
    out.add(Org(0))
    out.branch("target", None)
    nops(out, skipped)
    out.label("target", None)
    out.emit(Insn("RET"))
    data = code(out)
    if long:
        assert data[:5] == bytes([JNC, 3, LJMP, 0, 5 + skipped])
    else:
        assert data[:2] == bytes([JC, skipped])
    assert data[-1] == 0x22  # the RET at the target


@pytest.mark.parametrize(("skipped", "long"), [(126, False), (127, True)])
def test_a_backward_branch_grows_exactly_when_its_target_is_out_of_reach(skipped, long):
    out = OutputStream()
    out.add(Org(0x100))
    out.label("target", None)
    nops(out, skipped)
    out.branch("target", None)
    data = code(out)
    if long:
        assert data[skipped:] == bytes([JNC, 3, LJMP, 0x01, 0x00])
    else:
        assert data[skipped:] == bytes([JC, (-(skipped + 2)) & 0xFF])


def test_a_grown_branch_can_push_another_out_of_reach():
    """The first branch reaches its target only while the second, which it jumps over,
    stays short: it grows in the second round."""
    out = OutputStream()
    out.add(Org(0))
    out.branch("near", None)  # item 1: 2 + 2 + 123 = 127 bytes to go while item 2 is short
    out.branch("far", None)  # item 2: out of reach from the start
    nops(out, 123)
    out.label("near", None)
    nops(out, 200)
    out.label("far", None)
    assert out.relax({}) == {1, 2}
    near, far = 5 + 5 + 123, 5 + 5 + 123 + 200
    assert code(out)[:10] == bytes([JNC, 3, LJMP, 0, near, JNC, 3, LJMP, far >> 8, far & 0xFF])


def test_the_listing_lines_of_a_long_branch_carry_its_il_span():
    from asictl.diagnostics import Span

    span = Span("main.asi", 7, 1, 2)
    out = OutputStream()
    out.branch("far", span)
    nops(out, 200)
    out.label("far", None)
    out.add(End())
    output = out.assemble({})
    assert [(line.text.strip(), line.span) for line in output.lines[:3]] == [
        ("JNC ?J1", span), ("LJMP far", span), ("?J1:", span)
    ]


def test_peephole_rules_compare_objects():
    out = OutputStream()
    out.emit(Insn("CLR", (C,)))
    out.emit(Insn("MOV", (C, Bit(0x20))))  # overwrites the carry: the CLR C goes
    out.emit(Insn("RET"))
    out.emit(Insn("RET"))  # a second RET is never reached
    out.emit(Insn("LJMP", (Ref("next"),)))
    out.label("next", None)  # a jump to the very next line goes
    out.emit(Insn("CLR", (C,)))
    out.emit(Insn("MOV", (A, Imm(1))))  # MOV A: the carry stays as CLR C left it
    assert out.items == [
        Insn("MOV", (C, Bit(0x20))), Insn("RET"), Mark("next"),
        Insn("CLR", (C,)), Insn("MOV", (A, Imm(1))),
    ]


def test_hand_written_lines_are_left_as_written():
    out = OutputStream()
    out.raw("        CLR C", None)
    out.emit(Insn("MOV", (C, Bit(0x20))))
    out.raw("RET", None)
    out.emit(Insn("RET"))
    assert [type(item) for item in out.items] == [Raw, Insn, Raw, Insn]


def test_references_come_from_operands_branches_and_hand_written_lines():
    out = OutputStream()
    out.emit(Insn("MOV", (DPTR, Imm("_?PSeg_"))))
    out.emit(Insn("LCALL", (Ref("_SendPrm_"),)))
    out.branch("?Uend", None)
    out.raw("        LCALL _GetPrm_ ; not _SetPrm_, a comment", None)
    out.raw("        DB '_Copy_'", None)
    assert out.references() == {"_?PSEG_", "_SENDPRM_", "?UEND", "_GETPRM_"}


def test_the_firmware_entry_points_are_those_the_code_refers_to():
    program = (
        "[PROGRAM]\n"
        "    A I 1.0\n"
        "    PARAM\n"
        "    ASM lcall _getpp_\n"
        "    BE\n"
        "[ASSEMBLY]\n"
        "; only a comment names _SetPP_\n"
        "    mov dptr,#_?PSeg_\n"
    )
    built = check(from_string("main.asi", program))
    assert built.program is not None, built.render()
    compiled = compile_program(built.program)
    assert set(compiled.used_entry_points()) == {"sendprm", "getpp"}


def test_an_assembler_error_in_hand_written_code_is_reported_at_its_il_line():
    program = "[PROGRAM]\n    A I 1.0\n    ASM ljmp nowhere\n    BE\n"
    built = check(from_string("main.asi", program))
    assert built.program is not None, built.render()
    with pytest.raises(DiagnosticError) as info:
        compile_program(built.program)
    (diagnostic,) = info.value.diagnostics
    assert diagnostic.span is not None and diagnostic.span.file != GENERATED
    assert (diagnostic.span.file, diagnostic.span.line) == ("main.asi", 3)
    assert "ljmp nowhere" in diagnostic.message


def test_the_code_generator_uses_no_regular_expressions():
    """Generated code is never searched as text: no module of the package imports re."""
    for path in sorted(PACKAGE.glob("*.py")):
        tree = python_ast.parse(path.read_text(), str(path))
        imported = {
            alias.name.split(".")[0]
            for node in python_ast.walk(tree)
            if isinstance(node, python_ast.Import)
            for alias in node.names
        } | {
            (node.module or "").split(".")[0]
            for node in python_ast.walk(tree)
            if isinstance(node, python_ast.ImportFrom)
        }
        assert not imported & {"re", "regex", "fnmatch"}, path.name
