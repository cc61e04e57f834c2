"""The install hints name what pyproject.toml's extras install, and work as written."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

from asictl.errors import EXTRAS, missing_extra

ROOT = Path(__file__).resolve().parents[1]
DECLARED = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]


@pytest.mark.parametrize("extra", sorted(EXTRAS))
def test_each_hint_names_the_extras_packages(extra: str):
    assert list(EXTRAS[extra]) == DECLARED[extra]


def test_all_is_every_user_extra():
    assert sorted(DECLARED["all"]) == sorted({p for ps in EXTRAS.values() for p in ps})
    assert set(DECLARED) - set(EXTRAS) == {"all", "test"}


def test_a_hint_never_names_the_unpublished_package():
    message = str(missing_extra("--plot", "plot"))
    assert "asictl[" not in message
    assert "pip install 'matplotlib>=3.7'" in message and "pip install '.[plot]'" in message


def test_no_text_names_the_unpublished_package():
    """``pip install 'asictl[x]'`` fails: asictl is not on PyPI (with a git URL it works)."""
    vscode = ROOT / "editors" / "vscode"
    places = [*ROOT.glob("*.md"), *(ROOT / "docs").rglob("*.md"), *(ROOT / "src").rglob("*.py"),
              vscode / "package.json", vscode / "README.md"]
    by_name = re.compile(r"install '?asictl\[[a-z,]+\]'?(?! @)")  # '... @ git+URL' works
    wrong = [str(p.relative_to(ROOT)) for p in places if by_name.search(p.read_text())]
    assert wrong == []
