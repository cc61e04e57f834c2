"""The README's test command: its wall time, the install's and pytest's share, the CPU it
used (its processes and theirs), and the test files that used it (docs/performance.md,
"The test suite").

Runs the README's second command from the repository's root, ``python3 -m pip install -e
'.[test,plot]' && python3 -m pytest -n auto``, with this file loaded into pytest as a
plugin (``-p bench_suite``): around every test it reads ``getrusage`` of the worker and
of the processes the worker waited for, so that a test's CPU counts the ``asictl``
commands, servers and oracles it started. The two cores of the reference machine are busy
all through the run, so the CPU, not the waits, is what a shorter run must take out.
Extra arguments go to pytest. Usage:

    python3 benchmarks/bench_suite.py [--top 25] [--no-install] [pytest arguments]
"""

from __future__ import annotations

import argparse
import collections
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Generator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
INSTALL = [sys.executable, "-m", "pip", "install", "-q", "-e", ".[test,plot]"]
_LOG = "BENCH_SUITE_LOG"


def _cpu() -> tuple[float, float]:
    own = resource.getrusage(resource.RUSAGE_SELF)
    waited = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, waited.ru_utime + waited.ru_stime


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(item: pytest.Item) -> Generator[None, object, object]:
    """The plugin: a test's CPU, its own and its subprocesses', one line per test."""
    folder = os.environ.get(_LOG)
    own, waited = _cpu()
    try:
        return (yield)
    finally:
        if folder:
            own_after, waited_after = _cpu()
            worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
            with open(Path(folder, worker), "a", encoding="utf-8") as log:
                log.write(f"{own_after - own:.3f}\t{waited_after - waited:.3f}\t"
                          f"{item.nodeid}\n")


def _timed(command: list[str], env: dict[str, str]) -> tuple[float, float, int]:
    """Wall time, CPU of the command and everything it waited for, exit status."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.monotonic()
    status = subprocess.run(command, cwd=ROOT, env=env, check=False).returncode
    wall = time.monotonic() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    return wall, cpu, status


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--top", type=int, default=25, help="test files listed (25)")
    parser.add_argument("--no-install", action="store_true",
                        help="the pytest run alone, without the README's pip install")
    options, pytest_args = parser.parse_known_args()
    with tempfile.TemporaryDirectory(prefix="bench-suite-") as folder:
        env = {**os.environ, _LOG: folder, "PYTHONPATH": os.pathsep.join(
            [str(ROOT / "benchmarks"), os.environ.get("PYTHONPATH", "")])}
        install = (0.0, 0.0, 0) if options.no_install else _timed(INSTALL, env)
        if install[2]:
            return install[2]
        run = _timed([sys.executable, "-m", "pytest", "-n", "auto", "-p", "bench_suite",
                      "-q", *pytest_args], env)
        own: collections.defaultdict[str, float] = collections.defaultdict(float)
        waited: collections.defaultdict[str, float] = collections.defaultdict(float)
        tests = 0
        for log in Path(folder).iterdir():
            for line in log.read_text(encoding="utf-8").splitlines():
                mine, theirs, nodeid = line.split("\t", 2)
                file = nodeid.split("::")[0]
                own[file] += float(mine)
                waited[file] += float(theirs)
                tests += 1
    in_tests = sum(own.values()) + sum(waited.values())
    if options.no_install:
        print(f"\npytest -n auto: {run[0]:.1f} s (exit {run[2]})")
    else:
        print(f"\nREADME's test command: {install[0] + run[0]:.1f} s (install "
              f"{install[0]:.1f} s, pytest {run[0]:.1f} s, exit {run[2]})")
    print(f"CPU (user + system, every process): {install[1] + run[1]:.0f} s, of which "
          f"{in_tests:.0f} s in {tests} tests ({sum(waited.values()):.0f} s in the "
          f"processes they started)")
    print(f"\n{'CPU s':>7} {'theirs':>7}  test file")
    spent = {path: own[path] + waited[path] for path in own}
    for path in sorted(spent, key=spent.__getitem__, reverse=True)[:options.top]:
        print(f"{spent[path]:7.1f} {waited[path]:7.1f}  {path}")
    return run[2]


if __name__ == "__main__":
    sys.exit(main())
