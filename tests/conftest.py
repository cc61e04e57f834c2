"""Shared test fixtures.

External oracles (as31, ucsim's s51) are skipped loudly when absent on a developer's
machine, but must be present in CI: there a missing oracle fails the run, so a green CI
always means the differential tests really ran.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import stat
import sys
from collections.abc import Generator
from pathlib import Path

import pytest
from click.testing import CliRunner
from compile_once import compile_once

pytest_plugins = ["pytester"]

# The scenarios here are tested by the tests that name them; asictl's pytest plugin
# (active wherever asictl is installed) must not collect them a second time.
collect_ignore_glob = ["scenarios/*.scenario.toml"]


# Bytecode is written as Python writes it by default (into the gitignored __pycache__
# folders), even where PYTHONDONTWRITEBYTECODE is set: otherwise each of the suite's
# hundreds of ``asictl`` processes compiles every module it imports anew, and each
# worker rewrites every test module's asserts anew (half of its collection).
sys.dont_write_bytecode = False
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)


def pytest_configure(config: pytest.Config) -> None:
    """With pytest-xdist's workers (``-n auto``), tests are handed out by work stealing
    rather than in fixed shares: a worker that is done takes over the queue of one that
    is not, so a long test near the end does not leave the other worker idle. And the
    workers start on bytecode compiled once, before them (``compile_once``)."""
    if getattr(config.option, "dist", None) == "load":
        config.option.dist = "worksteal"
    if getattr(config.option, "numprocesses", None) and not hasattr(config, "workerinput"):
        compile_once()


@pytest.hookimpl(wrapper=True, optionalhook=True)  # a hook of pytest-xdist's
def pytest_xdist_auto_num_workers(config: pytest.Config) -> Generator[None, int, int]:
    """``-n auto``: two workers for each core pytest-xdist counts (unless
    PYTEST_XDIST_AUTO_NUM_WORKERS names the number). A quarter of a worker's time is
    spent waiting (on served boards, terminals, browsers, subprocesses and real-time
    holds), during which one worker per core leaves its core idle."""
    cores = yield
    return cores if os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS") else 2 * cores


@pytest.fixture(scope="session")
def _cache_home(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """This worker's XDG cache folder, the one every test of it uses (``_own_cache``)."""
    return tmp_path_factory.getbasetemp() / "cache"


@pytest.fixture(scope="session")
def _shared_caches(tmp_path_factory: pytest.TempPathFactory, _cache_home: Path) -> list[Path]:
    """The cache files each test's cache folder links to: the analysed grammars
    (``files.grammar_cache``), built once in this worker by the code that builds them for
    a command (tests/opcua adds asyncua's standard address space).

    They are built in the cache folder the tests use (``_own_cache``), then moved aside
    and linked back: lark's key for a cached grammar includes the path it was told to
    cache it at, so a grammar built under another path is built again by every process
    that reads it there (0.35 s of CPU)."""
    from asictl.il.parser import _Reader
    from asictl.observe import condition

    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("XDG_CACHE_HOME", str(_cache_home))
        _Reader()
        condition._parser.__wrapped__()
    kept = tmp_path_factory.getbasetemp() / "grammars"
    kept.mkdir()
    return [path.rename(kept / path.name) for path in sorted((_cache_home / "asictl").iterdir())]


@pytest.fixture(autouse=True)
def _own_cache(monkeypatch: pytest.MonkeyPatch, _cache_home: Path,
               _shared_caches: list[Path]) -> None:
    """Each test starts with an XDG cache folder that holds nothing but links to the
    shared caches (``asictl mutate`` keeps its verdicts there): a verdict one test's
    monkeypatching produced must never answer for another's run. The links spare each
    test's first ``asictl`` process building the IL grammar anew (0.35 s of CPU).

    The folder is the worker's, emptied of what the last test left rather than made anew
    for each test: four file-system writes a test were a millisecond of its time."""
    _empty_but_links(_cache_home / "asictl", {kept.name: kept for kept in _shared_caches})
    for entry in os.scandir(_cache_home):
        if entry.name != "asictl":
            _remove(Path(entry.path))
    monkeypatch.setenv("XDG_CACHE_HOME", str(_cache_home))


def _empty_but_links(folder: Path, links: dict[str, Path]) -> None:
    """``folder`` private (0700) and holding exactly ``links`` (name: target)."""
    try:
        mode = folder.lstat().st_mode
    except FileNotFoundError:
        mode = 0
    private = stat.S_ISDIR(mode) and stat.S_IMODE(mode) == 0o700
    if not private:
        _remove(folder)
        folder.mkdir(mode=0o700, parents=True)
    wanted = dict(links)
    for entry in os.scandir(folder):
        target = wanted.get(entry.name)
        if target is not None and entry.is_symlink() and os.readlink(entry.path) == str(target):
            del wanted[entry.name]
        else:
            _remove(Path(entry.path))
    for name, target in wanted.items():
        (folder / name).symlink_to(target)


def _remove(path: Path) -> None:
    """``path`` gone, a folder with all it holds."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()


def require_tool(name: str, package: str) -> str:
    """Return the path of an oracle program, or skip (locally) / fail (in CI) without it."""
    path = shutil.which(name)
    if path:
        return path
    message = (
        f"ORACLE MISSING: '{name}' not found; install the Debian package '{package}' "
        f"(apt-get install -y {package}) to run this differential test"
    )
    if os.environ.get("CI"):
        pytest.fail(message)
    pytest.skip(message)


@pytest.fixture(scope="session")
def as31_path() -> str:
    return require_tool("as31", "as31")


@pytest.fixture(scope="session")
def s51_path() -> str:
    return require_tool("s51", "sdcc-ucsim")


@pytest.fixture(scope="session")
def mbpoll_path() -> str:
    return require_tool("mbpoll", "mbpoll")


@pytest.fixture(scope="session")
def socat_path() -> str:
    return require_tool("socat", "socat")


@pytest.fixture(scope="session")
def chromium_paths() -> tuple[str, str]:
    """Debian's headless browser and its WebDriver (tests/web)."""
    return require_tool("chromium", "chromium"), require_tool("chromedriver", "chromium-driver")


@pytest.fixture
def runner() -> CliRunner:
    """Runs ``asictl`` commands in process, with stdout and stderr kept apart."""
    return CliRunner()
