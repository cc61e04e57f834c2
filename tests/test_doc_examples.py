"""Every Python and shell example in the README and docs/ runs, so none can drift.

A page's ``python`` blocks run in order in one interpreter (a later block may use what an
earlier one made, as a reader typing them would); each ``sh`` block runs in bash with
``set -e``, in a fresh folder holding a copy of demos/ and a prog.asi and prog.a51, with
``asictl`` and ``pytest`` standing for this checkout's Python. Jobs a block starts with
``&`` are stopped when it ends. An example that cannot run here says why on the line
before it, as ``<!-- example: not run: REASON -->`` (the reasons are listed by a test, so
a new one is seen in review); one that needs a server says which, as ``<!-- example:
served by: asictl gateway serve (tcp 5020) -->``, and the test starts it and waits for
its port. docs/tutorial.md and docs/debugging.md show ``console`` sessions with their
output; tests/test_tutorial.py and tests/test_debugging_doc.py run those.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
_FENCE = re.compile(r"^```(\w+)[^\n]*\n(.*?)^```$", re.M | re.S)
_NOT_RUN = re.compile(r"<!-- example: not run: (.+?) -->\s*\Z")
_SERVED = re.compile(r"<!-- example: served by: (asictl [^(]+?) \(tcp (\d+)\) -->\s*\Z")
_PRELUDE = """\
set -euo pipefail
asictl() { "$ASICTL_PY" -m asictl "$@"; }
pytest() { "$ASICTL_PY" -m pytest -p no:cacheprovider "$@"; }
"""


@dataclass(frozen=True)
class Example:
    page: Path
    line: int
    language: str
    text: str
    not_run: str | None
    served_by: tuple[str, int] | None = None

    @property
    def name(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def examples() -> list[Example]:
    found = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for match in _FENCE.finditer(text):
            language, body = match.groups()
            if language not in ("python", "sh"):
                continue
            before = text[: match.start()]
            reason = _NOT_RUN.search(before)
            served = _SERVED.search(before)
            line = before.count("\n") + 1
            found.append(Example(
                page, line, language, body, reason.group(1) if reason else None,
                (served.group(1), int(served.group(2))) if served else None,
            ))
    return found


def _environment(tmp_path: Path) -> dict[str, str]:
    return {
        **os.environ,
        "ASICTL_STATE_DIR": str(tmp_path / "state"),
        "ASICTL_PY": sys.executable,
        "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]),
    }


@contextlib.contextmanager
def _served(served_by: tuple[str, int] | None, folder: Path, tmp_path: Path) -> Iterator[None]:
    """The server an example talks to, up (its TCP port answers) for as long as it runs."""
    if served_by is None:
        yield
        return
    command, port = served_by
    # One at a time on this machine: examples name their server's port as a reader uses
    # it, and pytest-xdist's workers would otherwise start two servers on it.
    lock = (Path(tempfile.gettempdir()) / f"asictl-doc-example-{port}.lock").open("w")
    fcntl.flock(lock, fcntl.LOCK_EX)
    process = subprocess.Popen(
        [sys.executable, "-m", "asictl", *command.split()[1:]], cwd=folder,
        env=_environment(tmp_path), stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL, start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1).close()
                break
            except OSError:
                assert process.poll() is None and time.monotonic() < deadline, command
                time.sleep(0.1)
        yield
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGTERM)
        process.wait()
        lock.close()


def _run(example_or_script: str, language: str, folder: Path, tmp_path: Path) -> None:
    env = _environment(tmp_path)
    command = (
        [sys.executable, "-c", example_or_script]
        if language == "python"
        else ["bash", "-c", _PRELUDE + example_or_script]
    )
    # Its own session, so whatever an example leaves running (a server started with '&')
    # goes with its process group; output to files, which such a server does not hold open.
    out, err = tmp_path / "stdout", tmp_path / "stderr"
    with out.open("w") as stdout, err.open("w") as stderr:
        process = subprocess.Popen(
            command, cwd=folder, env=env, stdout=stdout, stderr=stderr,
            stdin=subprocess.DEVNULL, start_new_session=True,
        )
        try:
            process.wait(timeout=600)
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGTERM)
            process.wait()
    assert process.returncode == 0, (
        f"exit {process.returncode}\n--- stdout\n{out.read_text()}\n--- stderr\n{err.read_text()}"
    )


def _folder(tmp_path: Path, name: str = "work") -> Path:
    """A copy of demos/, and the program files the pages call prog.asi and prog.a51."""
    folder = tmp_path / name
    shutil.copytree(ROOT / "demos", folder / "demos")
    shutil.copy(ROOT / "demos" / "blink.asi", folder / "prog.asi")
    (folder / "prog.a51").write_text("        ORG 0\nstart:  MOV A,#2Ah\n        SJMP start\n")
    return folder


_RUN = [e for e in examples() if e.not_run is None]
_SHELL = [e for e in _RUN if e.language == "sh"]
_PYTHON_PAGES = sorted({e.page for e in _RUN if e.language == "python"})


@pytest.mark.parametrize("example", _SHELL, ids=[e.name for e in _SHELL])
def test_each_shell_example_runs(example: Example, tmp_path: Path) -> None:
    folder = _folder(tmp_path)
    with _served(example.served_by, folder, tmp_path):
        _run(example.text, "sh", folder, tmp_path)


@pytest.mark.parametrize(
    "page", _PYTHON_PAGES, ids=[str(p.relative_to(ROOT)) for p in _PYTHON_PAGES]
)
def test_each_pages_python_examples_run_in_order(page: Path, tmp_path: Path) -> None:
    blocks = [e for e in _RUN if e.page == page and e.language == "python"]
    served_by = next((e.served_by for e in blocks if e.served_by), None)
    folder = _folder(tmp_path)
    with _served(served_by, folder, tmp_path):
        _run("\n".join(e.text for e in blocks), "python", folder, tmp_path)


def test_the_examples_not_run_are_few_and_say_why() -> None:
    reasons = {e.name: e.not_run for e in examples() if e.not_run}
    assert all(len(reason) > 10 for reason in reasons.values()), reasons
    assert len(reasons) <= 12, reasons
    assert len(_RUN) >= 10


def test_a_failing_example_fails(tmp_path: Path) -> None:
    with pytest.raises(AssertionError, match="exit 2"):
        _run("asictl check no-such-file.asi", "sh", _folder(tmp_path, "a"), tmp_path)
    with pytest.raises(AssertionError, match="NameError"):
        _run("undefined_name", "python", _folder(tmp_path, "b"), tmp_path)
