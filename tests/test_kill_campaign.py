"""Kill campaigns: the writers of coverage, JUnit, counterexample, archive and recording
files are killed (SIGKILL, as the OOM killer or a pulled plug would end them) at random
points while they write, over and over; each file is then absent, the previous version
or the new one, whole, never a half file. A sized campaign runs by default; the full one
(at least 50 kills per writer) with ``-m slow``."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path
from xml.etree import ElementTree

import pytest

ROOT = Path(__file__).resolve().parent.parent

#: Each writer as the commands call it, writing version after version of a file of a
#: few hundred kilobytes (so that a kill lands inside a write) until it is killed.
CHILD = r"""
import sys
from pathlib import Path

from asictl.cli.sim import _junit
from asictl.files import open_atomic, write_atomic, write_output, write_together
from asictl.sim.session import Outcome

kind, folder = sys.argv[1], Path(sys.argv[2])
target = folder / "out"


def text(version: int) -> str:
    body = "".join(f"line {i} of version {version}\n" for i in range(20000))
    return f"version {version}\n{body}end {version}\n"


print("ready", flush=True)
version = 0
while True:
    version += 1
    if kind == "junit":
        _junit([Outcome(f"s{i}.scenario.toml", "PASS", seconds=version)
                for i in range(3000 + version % 7)], target, [])
    elif kind == "coverage":
        write_output(target, text(version), inputs=[])
    elif kind == "counterexample":
        write_atomic(target, text(version), follow_links=False)
    elif kind == "archive":
        write_together([(folder / name, text(version)) for name in ("a", "b", "c")])
    elif kind == "record":
        with open_atomic(target) as out:
            for chunk in text(version).splitlines(keepends=True):
                out.write(chunk)
"""


def _whole(path: Path, kind: str) -> bool:
    """Is the file (if there) a whole version?"""
    if not path.exists():
        return True
    data = path.read_bytes()
    if kind == "junit":
        try:
            suite = ElementTree.fromstring(data)
        except ElementTree.ParseError:
            return False
        return int(suite.get("tests", "-1")) == len(suite.findall("testcase"))
    lines = data.decode().splitlines()
    if not lines or not lines[0].startswith("version "):
        return False
    version = int(lines[0].split()[1])
    return lines[-1] == f"end {version}" and len(lines) == 20002


def _campaign(tmp_path: Path, kind: str, kills: int) -> None:
    folder = tmp_path / kind
    folder.mkdir()
    chance = random.Random(f"{kind}-{kills}")
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    seen = 0
    for kill in range(kills):
        child = subprocess.Popen([sys.executable, "-c", CHILD, kind, str(folder)],
                                 stdout=subprocess.PIPE, text=True, env=env)
        assert child.stdout is not None
        assert child.stdout.readline() == "ready\n"
        time.sleep(chance.uniform(0.0, 0.25))
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=30)
        child.stdout.close()
        assert child.returncode == -signal.SIGKILL
        names = ("a", "b", "c") if kind == "archive" else ("out",)
        for name in names:
            assert _whole(folder / name, kind), f"{kind}: kill {kill}: {name} is half written"
        seen += any((folder / name).exists() for name in names)
    assert seen, "no kill came after a first whole write: the campaign tested nothing"


KINDS = ["coverage", "junit", "counterexample", "archive", "record"]


@pytest.mark.parametrize("kind", KINDS)
def test_a_sized_kill_campaign_leaves_no_half_file(tmp_path: Path, kind: str):
    _campaign(tmp_path, kind, 5)


@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
def test_fifty_kills_per_writer_leave_no_half_file(tmp_path: Path, kind: str):
    _campaign(tmp_path, kind, 50)
