"""Each test's XDG cache folder (tests/conftest.py, ``_own_cache``) starts private and
holding only the links to the shared caches, whatever the test before it left there."""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("leaves", ["verdicts", "a replaced link", "an open folder"])
def test_each_test_starts_with_the_links_alone(leaves: str, _shared_caches: list[Path]) -> None:
    folder = Path(os.environ["XDG_CACHE_HOME"], "asictl")
    assert stat.S_IMODE(folder.lstat().st_mode) == 0o700
    assert {p.name: os.readlink(p) for p in folder.iterdir()} == \
        {p.name: str(p) for p in _shared_caches}
    assert os.listdir(folder.parent) == ["asictl"]
    # what this test leaves for the next one in this worker
    (folder / "mutate" / "key").mkdir(parents=True)
    (folder.parent / "elsewhere").write_text("x")
    if leaves == "a replaced link":
        first = folder / _shared_caches[0].name
        first.unlink()
        first.write_bytes(b"damaged")
    if leaves == "an open folder":
        folder.chmod(0o755)


def test_a_command_reads_the_shared_grammars_without_building_them(
        tmp_path: Path, _shared_caches: list[Path]) -> None:
    """lark keys a cached grammar by the path it caches it at, too: the grammars are
    built where the tests' commands look for them, so that none builds them again (and
    writes them through the link)."""
    shutil.copytree(ROOT / "demos", tmp_path / "demos")
    before = {path: path.stat() for path in _shared_caches}
    for command in (["check", "demos/blink.asi"], ["prove", "demos/blink.props.toml"]):
        subprocess.run([sys.executable, "-m", "asictl", *command], cwd=tmp_path, check=True,
                       capture_output=True)
    for path, status in before.items():
        now = path.stat()
        assert (now.st_mtime_ns, now.st_size) == (status.st_mtime_ns, status.st_size), path
