"""Bytecode for pytest-xdist's workers, compiled once before they start (tests/conftest.py).

A fresh checkout has no bytecode, so every worker would compile asictl and rewrite the
asserts of each test module itself, all of them at once (a cold start took 23 s against
13 s warm, with four workers on two cores). ``compile_once`` does it once, spread over
the cores. pytest has no public call that rewrites a file without importing it: its own
functions are used, and a pytest whose functions changed only costs the workers the time
they took before. (A module of its own, so that the pool's processes find ``rewrite``
by name: pytest imports several modules named ``conftest``.)
"""

from __future__ import annotations

import compileall
import re
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: the files pytest rewrites the asserts of, and compiles in its own way
REWRITTEN = re.compile(r"(test_[^/]*|conftest)\.py$")


def compile_once() -> None:
    compileall.compile_dir(ROOT / "src", quiet=1, workers=0)
    compileall.compile_dir(ROOT / "tests", quiet=1, workers=0, rx=REWRITTEN)
    rewritten = [path for path in (ROOT / "tests").rglob("*.py") if REWRITTEN.search(path.name)]
    with ProcessPoolExecutor() as pool:
        list(pool.map(rewrite, rewritten, chunksize=8))


class _Silent:
    """What pytest's writer of rewritten bytecode reports its failures to (they only
    leave the file to the worker that imports it)."""

    def trace(self, message: str) -> None:
        pass


def rewrite(path: Path) -> None:
    """The rewritten bytecode of one test module, where pytest's import looks for it."""
    try:
        from _pytest.assertion import rewrite as pytest_rewrite

        pyc = pytest_rewrite.get_cache_dir(path) / (path.name[:-3] + pytest_rewrite.PYC_TAIL)
        if pytest_rewrite._read_pyc(path, pyc) is not None:
            return
        stat, code = pytest_rewrite._rewrite_test(path, None)  # type: ignore[arg-type]
        if pytest_rewrite.try_makedirs(pyc.parent):
            pytest_rewrite._write_pyc(_Silent(), code, stat, pyc)  # type: ignore[arg-type]
    except Exception:  # another pytest's internals: the worker rewrites the file itself
        pass
