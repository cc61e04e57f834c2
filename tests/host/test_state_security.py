"""No other local user reads, locks or redirects a board: the state folder is owner-only,
its files are 0600 whatever the umask, a loose or foreign folder is refused, and a link
planted in it is replaced, never followed.

The tests with a second user run as root (as CI does) and act as ``nobody``.
"""

from __future__ import annotations

import json
import os
import stat
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner
from two_users import NOBODY, as_nobody, as_root

from asictl.cli import main

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"


def asictl(state: Path, *args: str) -> object:
    result = CliRunner().invoke(main, [*args, "--state-dir", str(state)])
    assert "Traceback" not in result.output
    return result


@pytest.fixture
def umask(request: pytest.FixtureRequest) -> Iterator[int]:
    old = os.umask(request.param)
    try:
        yield request.param
    finally:
        os.umask(old)


def modes(folder: Path) -> dict[str, int]:
    return {p.name: stat.S_IMODE(p.stat().st_mode) for p in [folder, *folder.iterdir()]}


@pytest.mark.parametrize("umask", [0o022, 0o000, 0o077], indirect=True)
def test_a_new_state_folder_is_0700_and_its_files_0600_whatever_the_umask(tmp_path, umask):
    state = tmp_path / "deep" / "state"
    assert asictl(state, "download", str(BLINK)).exit_code == 0
    assert modes(state) == {"state": 0o700, "pc2-300h.json": 0o600, "pc2-300h.lock": 0o600}


def test_a_folder_others_can_read_is_used_with_a_warning_and_left_as_it_is(tmp_path):
    state = tmp_path / "shared"
    state.mkdir(mode=0o755)
    os.chmod(state, 0o755)
    result = asictl(state, "download", str(BLINK))
    assert result.exit_code == 0
    assert "other users can look into the state directory (mode 0755)" in result.stderr
    assert modes(state) == {"shared": 0o755, "pc2-300h.json": 0o600, "pc2-300h.lock": 0o600}


@pytest.mark.parametrize("mode", [0o777, 0o775, 0o1777])
def test_a_folder_others_can_write_is_refused(tmp_path, mode: int):
    state = tmp_path / "loose"
    state.mkdir()
    os.chmod(state, mode)
    result = asictl(state, "status")
    assert result.exit_code == 2 and "other users can write the state directory" in result.stderr
    assert list(state.iterdir()) == []


@as_root
def test_a_folder_of_another_user_is_refused(tmp_path):
    state = tmp_path / "theirs"
    state.mkdir(mode=0o700)
    os.chown(state, NOBODY, NOBODY)
    result = asictl(state, "status")
    assert result.exit_code == 2 and "belongs to another user" in result.stderr
    assert list(state.iterdir()) == []


def test_a_link_planted_as_the_holder_file_is_replaced_not_followed(tmp_path):
    """A planted pc2-300h.holder once made even 'status' overwrite the link's target."""
    state = tmp_path / "state"
    assert asictl(state, "status").exit_code == 0
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    (state / "pc2-300h.holder").symlink_to(victim)
    (state / "pc2-300h.json").rename(tmp_path / "saved.json")
    (state / "pc2-300h.json").symlink_to(tmp_path / "saved.json")
    result = asictl(state, "status")
    assert victim.read_text() == "precious\n"
    assert result.exit_code == 2 and "symbolic link" in result.stderr  # the state file
    (state / "pc2-300h.json").unlink()
    assert asictl(state, "status").exit_code == 0
    assert victim.read_text() == "precious\n"
    assert not (state / "pc2-300h.holder").is_symlink()


def test_a_link_planted_as_the_lock_file_is_refused(tmp_path):
    state = tmp_path / "state"
    assert asictl(state, "status").exit_code == 0
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    (state / "pc2-300h.lock").unlink()
    (state / "pc2-300h.lock").symlink_to(victim)
    result = asictl(state, "status")
    assert result.exit_code == 2 and "symbolic link" in result.stderr
    assert victim.read_text() == "precious\n" and stat.S_IMODE(victim.stat().st_mode) != 0o600


@as_root
def test_another_user_can_neither_read_nor_lock_a_board(open_folder: Path):
    state = open_folder / "state"
    assert asictl(state, "download", str(BLINK)).exit_code == 0
    assert json.loads((state / "pc2-300h.json").read_text())  # the owner reads it
    peek = as_nobody("cat", str(state / "pc2-300h.json"))
    assert peek.returncode != 0 and "Permission denied" in peek.stderr
    state.chmod(0o755)  # even where the folder is open to look into, the files are not
    peek = as_nobody("cat", str(state / "pc2-300h.json"))
    assert peek.returncode != 0 and "Permission denied" in peek.stderr
    for name in ("pc2-300h.json", "pc2-300h.lock"):
        tried = as_nobody("flock", "--nonblock", "--shared", str(state / name), "true")
        assert tried.returncode != 0, name  # cannot open it: no lock held against us
    result = asictl(state, "status")
    assert result.exit_code == 0 and "in use" not in result.stderr
