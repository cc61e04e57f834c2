"""The VS Code extension's TextMate grammar, held against the parser.

``vscode-tmgrammar-test`` (npm, installed by .ci/run) runs the grammar with VS Code's own
TextMate engine: on ``editors/vscode/test/syntax.asi``, whose comments assert the scope
of every construct, and on the demos, whose tokens are checked here against the AST: every
operator, operand, label and comment the parser finds must carry the matching scope.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from asictl.il import ast
from asictl.il.parser import parse_text
from asictl.lsp.navigation import operator_span

ROOT = Path(__file__).resolve().parents[2]
EXTENSION = ROOT / "editors" / "vscode"
GRAMMAR = EXTENSION / "syntaxes" / "asi.tmLanguage.json"
DEMOS = sorted((ROOT / "demos").glob("*.asi")) + sorted((ROOT / "demos").glob("*.fb"))


def tool(name: str) -> Path:
    path = EXTENSION / "node_modules" / ".bin" / name
    if path.exists():
        return path
    message = (f"'{name}' is not installed: run 'npm ci --prefix editors/vscode' "
               "(.ci/run does) to test the grammar with VS Code's TextMate engine")
    if os.environ.get("CI"):
        pytest.fail(message)
    pytest.skip(message)


# ---------------------------------------------------------------- the files themselves


def _rules(value: object):
    if isinstance(value, dict):
        yield value
        for item in value.values():
            yield from _rules(item)
    elif isinstance(value, list):
        for item in value:
            yield from _rules(item)


def test_the_extension_declares_the_language_and_its_grammar():
    package = json.loads((EXTENSION / "package.json").read_text())
    (language,) = package["contributes"]["languages"]
    assert language["id"] == "asi" and set(language["extensions"]) == {".asi", ".fb"}
    (grammar,) = package["contributes"]["grammars"]
    assert grammar["scopeName"] == "source.asi"
    assert (EXTENSION / grammar["path"]).resolve() == GRAMMAR
    assert (EXTENSION / package["main"]).is_file()
    assert "vscode-languageclient" in package["dependencies"]
    json.loads((EXTENSION / "language-configuration.json").read_text())


def test_the_grammar_is_well_formed():
    grammar = json.loads(GRAMMAR.read_text())
    assert grammar["scopeName"] == "source.asi"
    repository = grammar["repository"]
    for rule in _rules(grammar):
        include = rule.get("include")
        if isinstance(include, str) and include.startswith("#"):
            assert include[1:] in repository, include
        for key in ("match", "begin", "end"):
            if isinstance(rule.get(key), str):
                re.compile(rule[key])  # the grammar keeps to what Python's re reads too
        if "begin" in rule:
            assert isinstance(rule.get("end"), str), rule["begin"]
        if "scopeName" in rule:
            continue  # the grammar's own display name
        names = [rule.get("name", ""), rule.get("contentName", "")]
        assert all(n == "" or n.endswith(".asi") for n in names if isinstance(n, str)), rule


# ------------------------------------------------------------- VS Code's engine


def test_the_scope_assertions_of_the_syntax_test():
    result = subprocess.run(
        [str(tool("vscode-tmgrammar-test")), "test/syntax.asi"], cwd=EXTENSION,
        capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr


def _snapshot(path: Path) -> list[tuple[str, list[tuple[int, int, str]]]]:
    """A .snap file as (source line, [(column, length, scopes)])."""
    lines: list[tuple[str, list[tuple[int, int, str]]]] = []
    for line in path.read_text().split("\n"):
        if line.startswith(">"):
            lines.append((line[1:], []))
        elif line.startswith("#") and lines:
            match = re.match(r"#( *)(\^+) (.*)", line)
            assert match, line
            lines[-1][1].append((len(match[1]) + 1, len(match[2]), match[3]))
    return lines


def _scopes(tokens: list[tuple[int, int, str]], column: int) -> str:
    """The scopes of the token at 1-based ``column``."""
    return next((s for start, n, s in tokens if start <= column < start + n), "")


def _expectations(module: ast.Module):
    """(line, column, scope) the grammar must give, from the parser's spans."""
    for section in module.sections:
        assert section.span
        yield section.span.line, section.span.column, "entity.name.section.asi"
        for node in ast.nodes(section):
            span = node.span
            if isinstance(node, ast.Label) and span:
                yield span.line, span.column, "entity.name.label.asi"
                continue
            operator = operator_span(node)
            if operator is not None:
                scope = ("keyword.control.segment.asi" if isinstance(node, ast.SegmentEnd)
                         else "keyword.control.asi")
                yield operator.line, operator.column, scope
            shown = isinstance(node, ast.Statement | ast.GatingLine) and not isinstance(
                node, ast.Param)  # (PARAM's answer in FY 127 is not in the text)
            for operand, _ in ast.operands(node) if shown else ():
                where = operand.span
                if where is None:
                    continue
                scope = ("variable.other.asi" if operand.kind is ast.OperandKind.VAR
                         else "storage.modifier.operand.asi")
                yield where.line, where.column, scope


def test_the_demos_are_coloured_as_the_parser_reads_them(tmp_path: Path):
    for demo in DEMOS:
        shutil.copy(demo, tmp_path / demo.name)
    result = subprocess.run(
        [str(tool("vscode-tmgrammar-snap")), "-u", "--config", "package.json",
         str(tmp_path / "*.asi"), str(tmp_path / "*.fb")],
        cwd=EXTENSION, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    checked = 0
    for demo in DEMOS:
        text = demo.read_text()
        snapshot = _snapshot(tmp_path / f"{demo.name}.snap")
        assert [line for line, _ in snapshot] == text.split("\n")
        module, diagnostics = parse_text(text, demo.name)
        assert diagnostics == []
        for line, column, scope in _expectations(module):
            scopes = _scopes(snapshot[line - 1][1], column)
            assert scope in scopes.split(), (demo.name, line, column, scope, scopes)
            checked += 1
        for number, (source, tokens) in enumerate(snapshot, 1):
            assert "invalid" not in " ".join(s for _, _, s in tokens), (demo.name, number)
            if ";" in source:
                comment = _scopes(tokens, source.index(";") + 1)
                assert "comment" in comment, (demo.name, number)
    assert checked > 300
