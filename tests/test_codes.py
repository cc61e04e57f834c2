"""The registry of diagnostic codes against the code that reports them and the docs."""

from __future__ import annotations

import ast
import re
from pathlib import Path

from asictl.codes import STAGES, TITLES, all_codes

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "asictl"
CODE = re.compile(r"[EW]\d{3}")


def test_every_code_has_a_title_and_one_stage():
    codes = [member.value for stage in STAGES for member in stage]
    assert len(codes) == len(set(codes))
    assert set(codes) == set(TITLES)
    for stage in STAGES:
        hundreds = {member.value[1] for member in stage}
        assert len(hundreds) == 1, f"{stage.__name__} spans stages {hundreds}"


def test_every_code_is_documented_with_its_title():
    doc = (ROOT / "docs" / "language.md").read_text(encoding="utf-8")
    for code, title in TITLES.items():
        assert f"| {code} | {title} |" in doc, f"{code} is not in docs/language.md's table"
    documented = set(re.findall(r"^\| ([EW]\d{3}) \|", doc, re.M))
    assert documented <= set(all_codes()), f"documented but unknown: {documented - set(TITLES)}"


def test_no_stage_reports_a_code_outside_the_registry():
    """A code is only ever written in codes.py: elsewhere a literal is a new, unregistered code."""
    found = []
    for path in sorted(SRC.rglob("*.py")):
        if path.name == "codes.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            literal = isinstance(node, ast.Constant) and isinstance(node.value, str)
            if literal and CODE.fullmatch(node.value):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {node.value}")
    assert found == []
