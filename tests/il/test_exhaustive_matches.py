"""Every dispatch over the kinds of the IL tree is exhaustive, and mypy proves it.

A walker that dispatches on statement, section, declaration or operand kinds with a
``match`` ends it in ``case _: assert_never(subject)``: mypy then reports every walker a
new kind is missing from (code that asks about one or two kinds uses ``isinstance``).
The first test holds every ``match`` in src to that form; the second shows mypy really
catches a forgotten kind through it.
"""

from __future__ import annotations

import ast as python
import os
import subprocess
import sys
from pathlib import Path
from typing import get_args

import pytest

from asictl.il import ast

SRC = Path(__file__).resolve().parents[2] / "src"
#: The node classes whose kinds walkers dispatch on.
KINDS = {
    cls.__name__
    for union in (ast.Statement, ast.Section, ast.Declaration)
    for cls in get_args(union)
} | {"GatingLine", "GatingTerm"}
OPERAND_KINDS = {member.name for member in ast.OperandKind}
#: How the source names the operand kinds: ``ast.OperandKind.F`` or an alias ``K.F``.
KIND_ENUMS = {"OperandKind", "K", "_K"}


def _names_a_kind(pattern: python.pattern) -> bool:
    for node in python.walk(pattern):
        if isinstance(node, python.MatchClass):
            cls = node.cls
            name = cls.attr if isinstance(cls, python.Attribute) else getattr(cls, "id", "")
            if name in KINDS:
                return True
        if isinstance(node, python.MatchValue) and isinstance(node.value, python.Attribute):
            base = node.value.value
            base_name = base.attr if isinstance(base, python.Attribute) else getattr(
                base, "id", "")
            if base_name in KIND_ENUMS and node.value.attr in OPERAND_KINDS:
                return True
    return False


def _kind_matches() -> list[tuple[str, python.Match]]:
    found = []
    for path in sorted(SRC.rglob("*.py")):
        tree = python.parse(path.read_text(), str(path))
        for node in python.walk(tree):
            if isinstance(node, python.Match) and any(
                    _names_a_kind(case.pattern) for case in node.cases):
                found.append((f"{path.relative_to(SRC)}:{node.lineno}", node))
    return found


def _ends_in_assert_never(match: python.Match) -> bool:
    last = match.cases[-1]
    if not (isinstance(last.pattern, python.MatchAs) and last.pattern.pattern is None
            and last.pattern.name is None and last.guard is None and len(last.body) == 1):
        return False
    statement = last.body[0]
    return (
        isinstance(statement, python.Expr) and isinstance(statement.value, python.Call)
        and getattr(statement.value.func, "id", "") == "assert_never"
        and len(statement.value.args) == 1
        and python.dump(statement.value.args[0]) == python.dump(match.subject)
    )


def test_every_match_over_the_tree_ends_in_assert_never():
    matches = _kind_matches()
    assert len(matches) >= 25  # the detector finds the walkers (it is not vacuous)
    assert {where.split(":")[0] for where, _ in matches} >= {
        "asictl/il/ast.py", "asictl/il/checks.py", "asictl/il/oracle.py",
        "asictl/codegen8051/emitter.py", "asictl/codegen8051/generate.py",
        "asictl/observe/view.py",
    }
    open_ended = [where for where, match in matches if not _ends_in_assert_never(match)]
    assert open_ended == []


def test_the_detector_tells_an_open_match_from_a_closed_one():
    def first_match(source: str) -> python.Match:
        node = next(n for n in python.walk(python.parse(source))
                    if isinstance(n, python.Match))
        assert isinstance(node, python.Match)
        return node

    closed = first_match("match s:\n case ast.Not(): pass\n case _: assert_never(s)\n")
    open_ = first_match("match s:\n case ast.Not(): pass\n case _: pass\n")
    kinds = first_match("match o.kind:\n case K.F: pass\n case _: assert_never(o)\n")
    assert _names_a_kind(closed.cases[0].pattern) and _names_a_kind(kinds.cases[0].pattern)
    assert _ends_in_assert_never(closed)
    assert not _ends_in_assert_never(open_)
    assert not _ends_in_assert_never(kinds)  # assert_never of another subject


FORGETFUL = '''
from typing import assert_never
from asictl.il import ast

def mark(statement: ast.Statement) -> str:
    match statement:
        case ast.Logic() | ast.Store() | ast.Count():
            return statement.op.value
        case (ast.Not() | ast.Load() | ast.Transfer() | ast.Arith() | ast.Compare()
              | ast.SegmentEnd() | ast.BlockEnd() | ast.Jump() | ast.CallFB() | ast.Param()
              | ast.Asm()):
            return statement.to_source()
        case _:
            assert_never(statement)

def width(operand: ast.Operand) -> int:
    K = ast.OperandKind
    match operand.kind:
        case K.I | K.I2 | K.Q | K.F | K.T | K.C | K.VAR:
            return 1
        case K.IB | K.I2B | K.QB | K.FY | K.PSEG | K.KB:
            return 8
        case K.FW | K.KT | K.KC | K.KW:
            return 16
        case _:
            assert_never(operand.kind)
'''


def test_mypy_names_the_kind_a_walker_forgets(tmp_path: Path):
    pytest.importorskip("mypy")
    snippet = tmp_path / "forgetful.py"
    snippet.write_text(FORGETFUL)
    result = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", "--follow-imports=silent",
         "--cache-dir", str(tmp_path / "cache"), str(snippet)],
        capture_output=True, text=True, timeout=300,
        env={**os.environ, "MYPYPATH": str(SRC)},
    )
    errors = [line for line in result.stdout.splitlines() if ": error:" in line]
    assert len(errors) == 2, result.stdout + result.stderr
    assert '"Label"' in errors[0] and "assert_never" in errors[0]
    assert "KP" in errors[1] and "assert_never" in errors[1]
