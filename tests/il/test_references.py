"""The reference index: every definition, read and write of labels, blocks, variables,
timers, counters, slaves and image operands, at the exact place in the source."""

from __future__ import annotations

from pathlib import Path

from hypothesis import given, settings
from il_strategies import modules

from asictl.diagnostics import Span
from asictl.il import ast
from asictl.il.checks import check_source
from asictl.il.loader import Program
from asictl.il.parser import parse_text
from asictl.il.references import Role, Symbol, SymbolKind, build_index
from asictl.source import from_string, read_source

DEMOS = Path(__file__).resolve().parents[2] / "demos"

PROGRAM = """\
[SETUP]
4: iiii, 0
5: oooo, 0
[DECL]
Level BYTE 2
T20 TIMER
[PROGRAM]
start:  A   I 4.0
        A   Level 1.3
        =   Q 5.2
        L   IB 4
        T   Level 0
        L   KT 500
        S   T 20
        L   KP 5.3
        JC  = start
[GATING]
Q 5.2 = I 4.0 and not T 20
"""


def index_of(text: str, name: str = "p.asi"):
    module, diagnostics = parse_text(text, name)
    assert diagnostics == []
    return build_index(Program(main=module))


def places(index, symbol: Symbol) -> list[tuple[int, int, str]]:
    return [(o.span.line, o.span.column, o.role.value) for o in index.of(symbol)]


def test_operands_slaves_variables_timers_and_labels():
    index = index_of(PROGRAM)
    assert places(index, Symbol(SymbolKind.OPERAND, "I 4.0")) == [(8, 13, "read"), (18, 9, "read")]
    assert places(index, Symbol(SymbolKind.OPERAND, "Q 5.2")) == [(10, 13, "write"),
                                                                  (18, 1, "write")]
    # slave 4: its [SETUP] line, its bits, and IB 4 (slaves 4 and 5)
    assert places(index, Symbol(SymbolKind.SLAVE, "4")) == [
        (2, 1, "define"), (8, 13, "read"), (11, 13, "read"), (18, 9, "read")]
    assert places(index, Symbol(SymbolKind.SLAVE, "5")) == [
        (3, 1, "define"), (10, 13, "write"), (11, 13, "read"), (15, 13, "use"), (18, 1, "write")]
    assert places(index, Symbol(SymbolKind.VARIABLE, "level")) == [
        (5, 1, "declare"), (9, 13, "read"), (12, 13, "write")]
    assert places(index, Symbol(SymbolKind.TIMER, "20")) == [
        (6, 1, "declare"), (14, 13, "write"), (18, 23, "read")]
    label = Symbol(SymbolKind.LABEL, "start", "p.asi")
    assert places(index, label) == [(8, 1, "define"), (16, 15, "use")]
    assert [o.span for o in index.definitions(label)] == [Span("p.asi", 8, 1, 5)]


def test_at_prefers_the_narrowest_and_the_operand_before_its_slave():
    index = index_of(PROGRAM)
    found = index.at("p.asi", 8, 15)  # inside "I 4.0"
    assert [o.symbol for o in found] == [Symbol(SymbolKind.OPERAND, "I 4.0"),
                                         Symbol(SymbolKind.SLAVE, "4")]
    assert index.at("p.asi", 16, 16)[0].symbol.kind is SymbolKind.LABEL  # "JC  = start"
    assert index.at("p.asi", 8, 12) == []  # the operator


def test_blocks_are_defined_in_their_own_file_and_labels_are_local():
    result = check_source(read_source(DEMOS / "fb.asi"))
    index = build_index(result.program)
    latch = Symbol(SymbolKind.BLOCK, "latch")
    assert [o.span.file for o in index.definitions(latch)] == [str(DEMOS / "latch.fb")]
    roles = sorted(o.role.value for o in index.of(latch))
    assert roles == ["declare", "define", "use"]
    # F 20.0 is written by the main program and read by the block
    f200 = places(index, Symbol(SymbolKind.OPERAND, "F 20.0"))
    assert sorted(r for _, _, r in f200) == ["read", "write"]
    done = [s for s in index.symbols(SymbolKind.LABEL) if s.name == "done"]
    assert [s.scope for s in done] == [str(DEMOS / "latch.fb")]


def test_names_compare_without_case():
    index = index_of("[DECL]\nLevel BYTE 1\n[PROGRAM]\nx: A LEVEL 0.0\n JU = X\n")
    assert len(index.of(Symbol(SymbolKind.VARIABLE, "level"))) == 2
    assert len(index.of(Symbol(SymbolKind.LABEL, "x", "p.asi"))) == 2


def _operands(module: ast.Module) -> list[object]:
    found: list[object] = []
    for section in module.sections:
        if isinstance(section, ast.ProgramSection):
            for s in section.statements:
                op = getattr(s, "operand", None) or getattr(s, "counter", None)
                # constants name nothing, but KP names its slave
                if op is not None and (op.kind not in ast.CONSTANTS
                                       or op.kind is ast.OperandKind.KP):
                    found.append(op)
        elif isinstance(section, ast.GatingSection):
            for line in section.lines:
                found += [line.target, *(t.operand for t in line.terms)]
    return found


@settings(max_examples=100, deadline=None)
@given(modules(file="gen.asi"))
def test_every_operand_is_indexed_at_its_own_text(module: ast.Module):
    text = module.to_source()
    parsed, diagnostics = parse_text(text, "gen.asi")
    assert diagnostics == []
    index = build_index(Program(main=parsed))
    lines = text.split("\n")

    def covered(span: Span) -> str:
        return lines[span.line - 1][span.column - 1:span.column - 1 + span.length]

    operand_places = {o.span for o in index.occurrences
                      if o.role in (Role.READ, Role.WRITE, Role.USE)
                      and o.symbol.kind not in (SymbolKind.LABEL, SymbolKind.BLOCK)}
    params = {s.span for s in parsed.statements() if isinstance(s, ast.Param)}
    assert operand_places == {op.span for op in _operands(parsed)} | params
    for o in index.occurrences:
        if o.span in params:  # PARAM writes the slave's answer in FY 127
            assert (o.symbol.name, o.role) == ("FY 127", Role.WRITE)
        elif o.symbol.kind is SymbolKind.OPERAND:
            assert covered(o.span).upper() == o.symbol.name
        elif o.symbol.kind in (SymbolKind.LABEL, SymbolKind.VARIABLE) and o.role in (
                Role.DEFINE, Role.DECLARE, Role.USE):
            assert covered(o.span).casefold() == o.symbol.name


def test_an_unreadable_block_gets_no_definition(tmp_path: Path):
    source = from_string(str(tmp_path / "m.asi"), "[DECL]\nB FB b.fb\n[PROGRAM]\n JU FB B\n")
    index = build_index(check_source(source).program)
    assert [o.role for o in index.definitions(Symbol(SymbolKind.BLOCK, "b"))] == [Role.DECLARE]
