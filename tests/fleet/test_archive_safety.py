"""``fleet backup`` touches only the files it wrote: the user's files in the archive stay
as git sees them (``git status --porcelain``, ``git ls-files --stage``), and a link, a
name leaving a folder or a file of the user's in the way fails that master alone."""

from __future__ import annotations

import json
import os
import subprocess
import time
from pathlib import Path

from test_fleet import BLINK, EDGE, asictl, git


def plant(tmp_path: Path, *names: str) -> Path:
    """Boards running blink.asi, one state directory each, named as the masters."""
    text = ""
    for name in names:
        (tmp_path / name).mkdir(mode=0o700)
        asictl("download", str(BLINK), "--start", "--state-dir", str(tmp_path / name))
        text += f'[masters.{name}]\nport = "300h"\nstate_dir = "{name}"\n\n'
    inventory = tmp_path / "plant.toml"
    inventory.write_text(text)
    return inventory


def backup(inventory: Path, archive: Path, code: int = 0) -> dict[str, object]:
    result = asictl("fleet", "backup", str(inventory), "--into", str(archive),
                    "--format", "json", code=code)
    report: dict[str, object] = json.loads(result.stdout)
    return report


def users_view(archive: Path, backed_up: set[str]) -> tuple[list[str], list[str]]:
    """git's view of the repository but for the backup's own files."""
    status = git(archive, "status", "--porcelain", "--untracked-files=all").splitlines()
    stage = git(archive, "ls-files", "--stage").splitlines()
    return status, [line for line in stage if line.split("\t")[1] not in backed_up]


def test_the_users_files_tracked_or_not_staged_or_not_stay(tmp_path: Path):
    inventory = plant(tmp_path, "pc-1")
    archive = tmp_path / "archive"
    backup(inventory, archive)
    folder = archive / "pc-1"
    (folder / "note.txt").write_text("untracked, mine\n")
    (folder / "staged.txt").write_text("staged, mine\n")
    (folder / "committed.txt").write_text("committed by me\n")
    git(archive, "add", "pc-1/committed.txt")
    git(archive, "-c", "user.name=u", "-c", "user.email=u@x", "commit", "-qm", "mine")
    (folder / "committed.txt").write_text("changed, not staged\n")
    git(archive, "add", "pc-1/staged.txt")
    (archive / "top.txt").write_text("beside the folders\n")
    ours = set(json.loads((folder / "identity.json").read_text())["files"])
    assert ours == {"blink.asi", "image.hex", "identity.json", "status.json"}
    before = users_view(archive, {f"pc-1/{f}" for f in ours})
    assert len(before[0]) == 4 and "A  pc-1/staged.txt" in before[0]

    again = backup(inventory, archive)  # the same program: nothing to commit
    assert again["commit"] is None and again["failed"] == []
    assert users_view(archive, {f"pc-1/{f}" for f in ours}) == before

    asictl("download", str(EDGE), "--start", "--state-dir", str(tmp_path / "pc-1"))
    changed = backup(inventory, archive)  # another program: blink.asi is the backup's
    assert changed["changed"] == ["pc-1"]
    assert not (folder / "blink.asi").exists() and (folder / "edge.asi").is_file()
    now = json.loads((folder / "identity.json").read_text())["files"]
    assert users_view(archive, {f"pc-1/{f}" for f in [*ours, *now]}) == before
    assert (folder / "note.txt").read_text() == "untracked, mine\n"
    assert (folder / "staged.txt").read_text() == "staged, mine\n"
    assert (folder / "committed.txt").read_text() == "changed, not staged\n"
    committed = git(archive, "show", "--name-only", "--format=", "HEAD").split()
    assert sorted(committed) == ["pc-1/blink.asi", "pc-1/edge.asi", "pc-1/identity.json",
                                 "pc-1/image.hex", "pc-1/status.json"]


def test_a_master_folder_that_is_a_link_fails_that_master_alone(tmp_path: Path):
    inventory = plant(tmp_path, "pc-1", "pc-2")
    archive = tmp_path / "archive"
    backup(inventory, archive)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "precious.txt").write_text("not the archive's\n")
    (elsewhere / "identity.json").write_text('{"files": ["precious.txt"]}\n')
    subprocess.run(["rm", "-r", str(archive / "pc-1")], check=True)
    (archive / "pc-1").symlink_to(elsewhere, target_is_directory=True)
    git(archive, "add", "pc-1")
    git(archive, "-c", "user.name=u", "-c", "user.email=u@x", "commit", "-qm", "a link")
    asictl("download", str(EDGE), "--start", "--state-dir", str(tmp_path / "pc-2"))

    report = backup(inventory, archive, code=1)
    assert report["failed"] == ["pc-1"] and report["changed"] == ["pc-2"]
    rows = {row["master"]: row for row in report["masters"]}  # type: ignore[attr-defined]
    assert rows["pc-1"]["result"] == "FAILED"
    assert "a symbolic link, not a folder" in rows["pc-1"]["error"]
    assert sorted(p.name for p in elsewhere.iterdir()) == ["identity.json", "precious.txt"]
    assert (elsewhere / "precious.txt").read_text() == "not the archive's\n"
    assert git(archive, "status", "--porcelain") == ""


def test_a_listed_name_outside_the_folder_or_a_linked_file_is_refused(tmp_path: Path):
    inventory = plant(tmp_path, "pc-1", "pc-2")
    archive = tmp_path / "archive"
    backup(inventory, archive)
    outside = archive / "outside.txt"
    outside.write_text("the user's\n")
    identity = json.loads((archive / "pc-1" / "identity.json").read_text())
    identity["files"].append("../outside.txt")
    (archive / "pc-1" / "identity.json").write_text(json.dumps(identity))
    victim = tmp_path / "victim.hex"
    victim.write_text("not an image\n")
    (archive / "pc-2" / "image.hex").unlink()
    (archive / "pc-2" / "image.hex").symlink_to(victim)
    for name in ("pc-1", "pc-2"):
        asictl("download", str(EDGE), "--start", "--state-dir", str(tmp_path / name))

    report = backup(inventory, archive, code=1)
    assert report["failed"] == ["pc-1", "pc-2"] and report["commit"] is None
    errors = {row["master"]: row["error"] for row in report["masters"]}  # type: ignore[attr-defined]
    assert "names one outside the folder" in errors["pc-1"]
    assert "image.hex: not a plain file" in errors["pc-2"]
    assert outside.read_text() == "the user's\n" and victim.read_text() == "not an image\n"
    assert (archive / "pc-1" / "blink.asi").is_file()
    assert not (archive / "pc-1" / "edge.asi").exists()


def test_a_file_of_the_users_where_the_backup_writes_is_not_replaced(tmp_path: Path):
    inventory = plant(tmp_path, "pc-1")
    archive = tmp_path / "archive"
    (archive / "pc-1").mkdir(parents=True)
    subprocess.run(["git", "init", "-q", str(archive)], check=True)
    (archive / "pc-1" / "blink.asi").write_text("my own blink\n")
    report = backup(inventory, archive, code=1)
    assert report["failed"] == ["pc-1"] and report["commit"] is None
    assert "a file the backup did not write" in report["masters"][0]["error"]  # type: ignore[index]
    assert (archive / "pc-1" / "blink.asi").read_text() == "my own blink\n"
    assert sorted(p.name for p in (archive / "pc-1").iterdir()) == ["blink.asi"]


def kill_nine_leftovers(archive: Path) -> None:
    """What a git run killed with SIGKILL leaves: its locks, and nothing alive."""
    for name in ("index.lock", "HEAD.lock", "next-index-4242.lock"):
        lock = archive / ".git" / name
        lock.write_bytes((archive / ".git" / "index").read_bytes() if "index" in name
                         else b"")
        os.utime(lock, (time.time() - 60, time.time() - 60))


def test_a_stale_git_lock_is_removed_and_the_backup_goes_on(tmp_path: Path):
    inventory = plant(tmp_path, "pc-1")
    archive = tmp_path / "archive"
    backup(inventory, archive)
    kill_nine_leftovers(archive)
    verify = asictl("fleet", "verify", str(inventory), "--against", str(archive),
                    "--format", "json", code=1)
    assert json.loads(verify.stdout)["masters"][0]["result"] == "identical"
    assert f"not in a clean state: {archive / '.git' / 'index.lock'}: git's lock" in (
        verify.stderr)

    asictl("download", str(EDGE), "--start", "--state-dir", str(tmp_path / "pc-1"))
    result = asictl("fleet", "backup", str(inventory), "--into", str(archive))
    assert "removed git's lock left by a git run that was killed" in result.stderr
    assert "(1 changed)" in result.stdout
    assert not list((archive / ".git").glob("*.lock"))
    assert git(archive, "rev-list", "--count", "HEAD").strip() == "2"
    asictl("fleet", "verify", str(inventory), "--against", str(archive))


def test_a_lock_a_live_git_holds_stays_and_says_how_to_remove_it(tmp_path: Path):
    inventory = plant(tmp_path, "pc-1")
    archive = tmp_path / "archive"
    backup(inventory, archive)
    kill_nine_leftovers(archive)
    # a git at work in the archive: its current folder there, as git's own would be
    worker = subprocess.Popen(["git", "cat-file", "--batch"], cwd=archive,
                              stdin=subprocess.PIPE, stdout=subprocess.DEVNULL)
    try:
        result = asictl("fleet", "backup", str(inventory), "--into", str(archive), code=1)
    finally:
        worker.communicate(b"")
    assert f"process {worker.pid} works in the archive" in result.stderr
    assert f"rm {archive / '.git' / 'index.lock'}" in result.stderr
    assert (archive / ".git" / "index.lock").exists()


def test_verify_fails_on_a_backup_killed_between_writing_and_committing(tmp_path: Path):
    inventory = plant(tmp_path, "pc-1")
    archive = tmp_path / "archive"
    backup(inventory, archive)
    (archive / "pc-1" / "note.txt").write_text("the user's: no concern of verify\n")
    asictl("fleet", "verify", str(inventory), "--against", str(archive))
    status = archive / "pc-1" / "status.json"
    status.write_text(status.read_text().replace('"phase"', '"phase" '))
    result = asictl("fleet", "verify", str(inventory), "--against", str(archive), code=1)
    assert f"{status}: differs from the archive's last commit (M)" in result.stderr
    assert result.stdout.endswith(f"1 of 1 masters run what {archive} holds\n")


def test_an_archive_from_before_the_list_of_files_is_read_by_its_program_files(
    tmp_path: Path,
):
    inventory = plant(tmp_path, "pc-1")
    archive = tmp_path / "archive"
    backup(inventory, archive)
    identity_file = archive / "pc-1" / "identity.json"
    identity = json.loads(identity_file.read_text())
    del identity["files"]  # as an earlier asictl wrote it
    identity_file.write_text(json.dumps(identity))
    git(archive, "-c", "user.name=u", "-c", "user.email=u@x", "commit", "-qam", "older")
    (archive / "pc-1" / "note.txt").write_text("mine\n")
    asictl("download", str(EDGE), "--start", "--state-dir", str(tmp_path / "pc-1"))
    assert backup(inventory, archive)["changed"] == ["pc-1"]
    assert sorted(p.name for p in (archive / "pc-1").iterdir()) == [
        "edge.asi", "identity.json", "image.hex", "note.txt", "status.json"]
    assert git(archive, "status", "--porcelain") == "?? pc-1/note.txt\n"


def test_a_file_the_users_gitignore_names_is_written_but_not_committed(tmp_path: Path):
    inventory = plant(tmp_path, "pc-1")
    archive = tmp_path / "archive"
    archive.mkdir()
    subprocess.run(["git", "init", "-q", str(archive)], check=True)
    (archive / ".gitignore").write_text("status.json\n")
    report = backup(inventory, archive)
    assert report["changed"] == ["pc-1"]
    assert (archive / "pc-1" / "status.json").is_file()
    committed = git(archive, "show", "--name-only", "--format=", "HEAD").split()
    assert "pc-1/status.json" not in committed and "pc-1/image.hex" in committed
    assert git(archive, "status", "--porcelain") == "?? .gitignore\n"


def test_a_repository_whose_git_init_was_killed_is_completed(tmp_path: Path):
    inventory = plant(tmp_path, "pc-1")
    archive = tmp_path / "archive"
    (archive / ".git").mkdir(parents=True)  # killed after the folder, before its objects
    (archive / ".git" / "HEAD").write_text("ref: refs/heads/main\n")
    assert backup(inventory, archive)["changed"] == ["pc-1"]
    assert git(archive, "rev-list", "--count", "HEAD").strip() == "1"
