"""Generated ASTs survive printing and reading back, and every span covers its node."""

from __future__ import annotations

import dataclasses

import pytest
from hypothesis import given, settings
from il_strategies import modules

from asictl.diagnostics import Span
from asictl.il import ast
from asictl.il.parser import parse_text


def nodes(value: object):
    """Every AST node (a dataclass with a span) inside ``value``, depth first."""
    if isinstance(value, tuple):
        for item in value:
            yield from nodes(item)
    elif dataclasses.is_dataclass(value) and not isinstance(value, Span):
        if hasattr(value, "span"):
            yield value
        for f in dataclasses.fields(value):
            if f.name != "span":
                yield from nodes(getattr(value, f.name))


def canonical_text(node: object) -> str:
    """The text a node's span must cover in a file printed by ``to_source()``."""
    if isinstance(node, ast.Label):
        return node.name
    if isinstance(node, ast.AsmLine):
        return node.text
    if hasattr(node, "kind") and isinstance(node.kind, ast.SectionKind):
        return f"[{node.kind.value}]"
    return node.to_source() if hasattr(node, "to_source") else str(node)


@settings(max_examples=75, deadline=None)
@given(modules(file="gen.asi"))
def test_print_then_read_gives_the_same_ast(module: ast.Module) -> None:
    print_then_read_gives_the_same_ast(module)


@pytest.mark.slow
@settings(max_examples=600, deadline=None)
@given(modules(file="gen.asi"))
def test_print_then_read_gives_the_same_ast_long(module: ast.Module) -> None:
    print_then_read_gives_the_same_ast(module)


def print_then_read_gives_the_same_ast(module: ast.Module) -> None:
    text = module.to_source()
    again, diagnostics = parse_text(text, "gen.asi")
    assert diagnostics == []
    assert again == module
    lines = text.split("\n")
    for node in nodes(again.sections):
        span = node.span
        assert span is not None and span.file == "gen.asi", node
        covered = lines[span.line - 1][span.column - 1:span.column - 1 + span.length]
        assert covered == canonical_text(node), node
