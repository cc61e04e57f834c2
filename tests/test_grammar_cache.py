"""The analysed grammars are kept in asictl's private cache directory, per lark and Python
version, and a stale or damaged one is built anew (``files.grammar_cache``)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

#: A fresh process reads an IL program and conditions (two of them wrong, their errors
#: placed by the positions lark keeps); prints what it read.
READ_BOTH = """
from asictl.il.parser import parse
from asictl.observe.condition import ConditionError, parse_condition
from asictl.source import from_string
module, problems = parse(from_string("p.asi", "[PROGRAM]\\n A I 1.0\\n = Q 2.0\\n BE\\n[END]\\n"))
print(module, problems, parse_condition("Q 2.0 and not I 1.0 or IB 2 >= 3"))
print(parse(from_string("q.asi", "[PROGRAM]\\n A I 1.0\\n =  = Q 2.0\\n[END]\\n"))[1])
for wrong in ("Q 2.0 and IB 2 >= and", "Q 2.0 and IB 1 >= 3"):  # positions from the tree
    try:
        parse_condition(wrong)
    except ConditionError as error:
        print(vars(error))
"""


def read_both(cache_home: Path) -> str:
    env = {**os.environ, "XDG_CACHE_HOME": str(cache_home),
           "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    result = subprocess.run([sys.executable, "-c", READ_BOTH], env=env, capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 0 and result.stderr == "", result.stderr
    return result.stdout


def test_both_grammars_are_kept_in_the_private_cache_and_used_again(tmp_path: Path) -> None:
    first = read_both(tmp_path)
    kept = sorted(p.name for p in (tmp_path / "asictl").iterdir())
    assert [name.split("-grammar-")[0] for name in kept] == ["condition", "il"], kept
    assert all(name.endswith(f"-py{sys.version_info[0]}.{sys.version_info[1]}.cache")
               for name in kept)
    stamps = {p: p.stat().st_mtime_ns for p in (tmp_path / "asictl").iterdir()}
    assert read_both(tmp_path) == first
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps  # loaded, not written again


@pytest.mark.parametrize("damage", [b"", b"0" * 64 + b"\n", b"\x80\x04 not a pickle"])
def test_a_damaged_or_stale_cache_is_built_anew(tmp_path: Path, damage: bytes) -> None:
    first = read_both(tmp_path)
    for path in (tmp_path / "asictl").iterdir():
        path.write_bytes(damage)
    assert read_both(tmp_path) == first
    assert all(p.stat().st_size > 1000 for p in (tmp_path / "asictl").iterdir())


def test_no_cache_where_the_directory_is_not_the_users_alone(tmp_path: Path) -> None:
    (tmp_path / "asictl").mkdir(mode=0o777)
    (tmp_path / "asictl").chmod(0o777)  # writable by others: a pickle there is not loaded
    first = read_both(tmp_path)
    assert list((tmp_path / "asictl").iterdir()) == []
    assert first.strip()
