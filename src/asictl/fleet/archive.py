"""The fleet's archive: a folder per master in a git repository (docs/fleet.md).

``DIR/<name>/`` holds what an upload of the master writes (its source files, or [RAW]
records; its symbol table where the upload gives one), ``image.hex`` (the EEPROM image
exactly, what ``fleet verify`` compares the master with; for a program not in asictl's
format the EEPROM byte for byte, a raw image), ``identity.json`` (the master
and its program) and ``status.json`` (the state that stays put while the program runs:
phase, mode, lists, configuration, control state; not the data, flags, timers or cycle
times, which change every cycle and would make every backup a change). A run commits
what changed in one commit whose message lists it; a run that changed nothing commits
nothing. git runs as a subprocess with its author and committer given, so an archive
works on a machine without a git identity, and with the user's hooks and signing off.

A backup touches only the files it wrote itself: identity.json lists them (``files``), and
only those are replaced, removed, staged and committed; whatever else is in a master's
folder or the repository, tracked or not, staged or not, stays as it is. A master's folder
that is a symbolic link (or not a folder), a listed file that is a link, a name that would
leave the folder, or a file of the user's where the backup would write one of its own:
that master fails with the reason, and the others go on.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from asictl.errors import ExitCode, UserError
from asictl.files import write_together
from asictl.fleet.gitlocks import clear_stale_locks, git_locks
from asictl.fleet.inventory import FleetMaster
from asictl.host.master import Master
from asictl.host.program_files import uploaded_files
from asictl.host.raw_image import holds_raw_program, read_eeprom, to_hex, used
from asictl.host.raw_image import identity as raw_identity
from asictl.host.status import MasterStatus, read_program
from asictl.host.transfer import upload_head
from asictl.image.eeprom import ProgramImage
from asictl.source import SYMBOLS_SUFFIX

IMAGE_FILE = "image.hex"
IDENTITY_FILE = "identity.json"
STATUS_FILE = "status.json"
#: The main file's name when the image carries no source (or a name unfit for a file).
RAW_NAME = "program.asi"
#: Who commits, whatever the machine's git configuration says.
AUTHOR = {"name": "asictl fleet backup", "email": "asictl@localhost"}


@dataclass(frozen=True)
class Snapshot:
    """What a backup read from one master: its program image (None: the EEPROM holds
    none of asictl's format), its status, and the EEPROM byte for byte where it holds a
    program in another format (host.raw_image)."""

    image: ProgramImage | None
    status: MasterStatus
    raw: bytes | None = None


def take_snapshot(_: FleetMaster, master: Master) -> Snapshot:
    """Upload the master's program (as ``asictl upload`` does) and read its status."""
    program = read_program(master.transport)
    status = master.quick_status(program) if master.quick_status is not None else master.status()
    raw = None
    if program.image is None and holds_raw_program(upload_head(master.transport)):
        raw = used(read_eeprom(master.transport))
    return Snapshot(program.image, status, raw)


def snapshot_identity(snapshot: Snapshot) -> str | None:
    """The program's identity: asictl's, or a raw image's (``raw-`` and its SHA-256)."""
    if snapshot.image is not None:
        return snapshot.image.identity_hex
    return None if snapshot.raw is None else raw_identity(snapshot.raw)


def main_name(image: ProgramImage) -> str:
    """The main file's name as compiled (it is part of the program's identity), or
    ``RAW_NAME`` for an image without source or with a name that is no plain file name."""
    name = next(iter(image.sources()), RAW_NAME)
    plain = name.isprintable() and Path(name).name == name and name not in ("", ".", "..")
    return name if plain and not name.startswith(".") and name not in _OWN_FILES else RAW_NAME


_OWN_FILES = (IMAGE_FILE, IDENTITY_FILE, STATUS_FILE)


def _stable_status(status: MasterStatus) -> dict[str, Any]:
    data = status.to_json()
    kept = (
        "phase", "mode", "config_ok", "power_fail", "lps", "lds", "las", "missing",
        "unexpected", "wrong_profile", "control_state", "stop_reason", "program_status",
        "start_flag", "ignore_config_errors", "wait_for_set_button", "map_counters",
        "control_active", "stop_line", "los",
    )
    out = {key: data[key] for key in kept}
    out["slaves"] = {
        address: {key: slave[key] for key in ("pcd", "cdi", "pp", "lists")}
        for address, slave in data["slaves"].items()
    }
    return out


def snapshot_files(master: FleetMaster, snapshot: Snapshot) -> dict[str, bytes]:
    """The archive folder's files for one master: name -> exact bytes."""
    image, status = snapshot.image, snapshot.status
    files: dict[str, bytes] = {}
    program: dict[str, Any] | None = None
    if image is not None:
        uploaded = uploaded_files(image, main_name(image))
        files.update({path.name: data for path, data in uploaded})
        files[IMAGE_FILE] = image.to_hex().encode("ascii")
        names = [path.name for path, _ in uploaded]
        program = {
            "identity": image.identity_hex, "size": len(image.to_bytes()),
            "code_size": len(image.code), "source_included": bool(image.source),
            "files": names,
            "symbols": next((n for n in names if n.endswith(SYMBOLS_SUFFIX)), None),
        }
    if snapshot.raw is not None:
        files[IMAGE_FILE] = to_hex(snapshot.raw).encode("ascii")
        program = {"identity": raw_identity(snapshot.raw), "size": len(snapshot.raw),
                   "format": "raw: not asictl's, the EEPROM byte for byte"}
    identity = {
        "master": master.name, "reached": master.reached, "line": master.line,
        "groups": list(master.groups), "master_name": status.master_name,
        "version_id": status.version_id, "installed_software": status.installed_software,
        "program": program,
    }
    files[STATUS_FILE] = _json(_stable_status(status))
    identity["files"] = sorted([*files, IDENTITY_FILE])
    files[IDENTITY_FILE] = _json(identity)
    return files


def _plain(name: object) -> bool:
    """A name of a file right inside a folder: no separator, not ``.`` or ``..``."""
    return (isinstance(name, str) and name not in ("", ".", "..") and "/" not in name
            and "\0" not in name)


def _written_before(folder: Path) -> set[str]:
    """The files an earlier backup wrote in ``folder``, as its identity.json lists them
    (an archive from before that list: the files it names and the backup's own)."""
    identity = _identity_in(folder)
    if identity is None:
        return set()
    listed = identity.get("files")
    if listed is None:
        program = identity.get("program")
        named = program.get("files", []) if isinstance(program, dict) else []
        listed = [*_OWN_FILES, *(named if isinstance(named, list) else [])]
    if not isinstance(listed, list) or not all(_plain(name) for name in listed):
        raise UserError(
            f"{folder / IDENTITY_FILE}: its list of files names one outside the folder; "
            "a backup writes nothing there (restore the file from the archive's history)",
            ExitCode.FAILED,
        )
    return set(listed)


def _json(data: object) -> bytes:
    return (json.dumps(data, indent=2, sort_keys=True) + "\n").encode("utf-8")


class Archive:
    """The archive folder and its git repository."""

    def __init__(self, root: Path) -> None:
        self.root = root
        #: git's locks that ``open`` found stale (a git run killed) and removed
        self.recovered: list[Path] = []

    def open(self) -> None:
        """Make the folder and its repository if there are none yet. A folder with other
        content that is no repository is not taken over (its files would be committed).
        Locks a killed git left are removed when provably stale (fleet.gitlocks)."""
        if self.root.exists() and not self.root.is_dir():
            raise UserError(f"{self.root}: exists and is not a folder")
        if (self.root / ".git").exists():
            try:
                self.git("rev-parse", "--git-dir")
            except UserError:  # a git init killed halfway: init completes it, safely
                self.git("init", "--quiet")
            self.recovered = clear_stale_locks(self.root)
            return
        if self.root.exists() and any(self.root.iterdir()):
            raise UserError(
                f"{self.root}: a folder with files in it and no git repository is not an "
                "archive: give a new or empty folder, or one a backup made"
            )
        self.root.mkdir(parents=True, exist_ok=True)
        self.git("init", "--quiet")

    def git(self, *args: str) -> str:
        if shutil.which("git") is None:
            raise UserError("the archive is a git repository: install git", ExitCode.FAILED)
        env = {
            **os.environ,
            "GIT_AUTHOR_NAME": AUTHOR["name"], "GIT_AUTHOR_EMAIL": AUTHOR["email"],
            "GIT_COMMITTER_NAME": AUTHOR["name"], "GIT_COMMITTER_EMAIL": AUTHOR["email"],
            "GIT_CONFIG_NOSYSTEM": "1", "GIT_LITERAL_PATHSPECS": "1",
        }
        result = subprocess.run(
            ["git", "-c", "commit.gpgsign=false", "-c", "core.hooksPath=/dev/null",
             "-c", "init.defaultBranch=main", "-C", str(self.root), *args],
            capture_output=True, text=True, env=env, check=False,
        )
        if result.returncode != 0:
            said = (result.stderr.strip() or result.stdout.strip()
                    or _how_it_ended(result.returncode))
            raise UserError(f"{self.root}: git {args[0]} failed: {said}", ExitCode.FAILED)
        return result.stdout

    def folder(self, name: str) -> Path:
        """The master's folder, right inside the archive and never through a link."""
        folder = self.root / name
        if not _plain(name):
            raise UserError(f"master '{name}': not a folder's name inside the archive",
                            ExitCode.FAILED)
        if folder.is_symlink():
            raise UserError(
                f"{folder}: a symbolic link, not a folder: a backup never writes through "
                "one (remove the link, then back up again)", ExitCode.FAILED,
            )
        if folder.exists() and not folder.is_dir():
            raise UserError(f"{folder}: exists and is not a folder", ExitCode.FAILED)
        return folder

    def write(self, name: str, files: dict[str, bytes]) -> list[str]:
        """Write the backup's ``files`` into the master's folder (together: all or none)
        and remove those an earlier backup wrote that this one has not; returns every
        path it wrote or removed (``name/file``), the paths to commit. Nothing else in
        the folder is touched: a link among those files, or a file of the user's where
        one is to be written, refuses the lot."""
        folder = self.folder(name)
        before = _written_before(folder)
        for file in sorted(before | set(files)):
            path = folder / file
            if path.is_symlink() or (path.exists() and not path.is_file()):
                raise UserError(f"{path}: not a plain file: a backup never writes or removes "
                                "through a link (remove it, then back up again)",
                                ExitCode.FAILED)
            if file not in before and path.exists():
                raise UserError(f"{path}: a file the backup did not write is where it writes "
                                "its own: rename or move it, then back up again",
                                ExitCode.FAILED)
        folder.mkdir(exist_ok=True)
        changed = [
            (folder / file, data) for file, data in files.items()
            if not (folder / file).is_file() or (folder / file).read_bytes() != data
        ]
        write_together(changed)
        for old in sorted(before - set(files)):
            (folder / old).unlink(missing_ok=True)
        return [f"{name}/{file}" for file in sorted(before | set(files))]

    def unclean(self, names: list[str]) -> list[str]:
        """Why the archive is not as a finished backup leaves it (empty: it is): not a
        git repository, a lock git left, or a file the backup wrote for one of the
        masters ``names`` that differs from the last commit (a backup killed halfway,
        an edit by hand)."""
        if not (self.root / ".git").is_dir():
            return [f"{self.root}: no git repository (not an archive 'fleet backup' made)"]
        locks = git_locks(self.root)
        if locks:
            return [f"{lock}: git's lock, left by a git run that did not finish "
                    "('fleet backup' removes it when no git runs on the archive)"
                    for lock in locks]
        problems: list[str] = []
        paths: list[str] = []
        for name in names:
            try:
                paths += [f"{name}/{file}" for file in sorted(_written_before(
                    self.folder(name)))]
            except UserError as exc:
                problems.append(str(exc))
        fields = self.git(
            "status", "--porcelain", "-z", "--no-renames", "--untracked-files=all", "--", *paths
        ).split("\0") if paths else []
        problems += [f"{self.root / field[3:]}: differs from the archive's last commit "
                     f"({field[:2].strip()})" for field in fields if field]
        return problems

    def commit(
        self, paths: list[str], failed: dict[str, str], programs: dict[str, str] | None = None
    ) -> tuple[str | None, list[str]]:
        """Commit ``paths`` (``Archive.write``'s, nothing else); returns the commit (None:
        nothing changed) and the masters whose folder changed. ``failed`` (name -> why)
        and ``programs`` (name -> how its program changed) go in the message."""
        if not paths:
            return None, []
        known = self.git("ls-files", "-z", "--", *paths).split("\0")
        ignored = self.git("ls-files", "-z", "--others", "--ignored", "--exclude-standard",
                           "--", *paths).split("\0")  # by the user's .gitignore: left out
        paths = [path for path in paths
                 if path in known or ((self.root / path).exists() and path not in ignored)]
        if not paths:
            return None, []
        names = list(dict.fromkeys(path.partition("/")[0] for path in paths))
        self.git("add", "--all", "--", *paths)
        fields = self.git(
            "diff", "--cached", "--name-status", "--no-renames", "-z", "--", *paths
        ).split("\0")
        changes = list(zip(fields[0:-1:2], fields[1::2], strict=False))
        by_master: dict[str, list[str]] = {}
        for status, path in changes:
            master, _, file = path.partition("/")
            by_master.setdefault(master, []).append(f"{_VERBS.get(status[:1], status)} {file}")
        if not by_master:
            return None, []
        changed = [name for name in names if name in by_master]
        title = (
            f"fleet backup: {len(changed)} master{'' if len(changed) == 1 else 's'} changed"
            f" ({', '.join(changed[:5])}{', ...' if len(changed) > 5 else ''})"
        )
        programs = programs or {}
        body = [
            f"{name}: " + "; ".join(filter(None, [programs.get(name), ", ".join(by_master[name])]))
            for name in changed
        ]
        if failed:
            body += ["", "not backed up:"] + [f"{name}: {why}" for name, why in failed.items()]
        # only the backup's files: whatever else the user has staged stays staged
        committed = [path for _, path in changes]
        self.git("commit", "--quiet", "-m", title, "-m", "\n".join(body), "--", *committed)
        return self.git("rev-parse", "HEAD").strip(), changed


_VERBS = {"A": "added", "M": "changed", "D": "removed"}


def archived_image(archive: Path, name: str) -> Path | None:
    """The archived image of master ``name``; None when the archive has none for it."""
    path = archive / name / IMAGE_FILE
    return path if path.is_file() else None


def program_change(archive: Path, name: str, files: dict[str, bytes]) -> str | None:
    """How a master's program changes from what ``archive`` holds to the identity.json in
    ``files``: ``program 20d70c72b6d2 -> 217f990c9624``; None when it stays."""

    def identity(data: dict[str, Any] | None) -> str:
        program = (data or {}).get("program")
        found = program.get("identity") if isinstance(program, dict) else None
        return str(found)[:12] if found else "none"

    before = identity(archived_identity(archive, name))
    after = identity(json.loads(files[IDENTITY_FILE]))
    return None if before == after else f"program {before} -> {after}"


def archived_identity(archive: Path, name: str) -> dict[str, Any] | None:
    """A master's identity.json in the archive; None without one (or an unreadable one)."""
    return _identity_in(archive / name)


def _identity_in(folder: Path) -> dict[str, Any] | None:
    path = folder / IDENTITY_FILE
    if path.is_symlink():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _how_it_ended(returncode: int) -> str:
    """What a git that said nothing died of: its exit status, or the signal that ended it."""
    if returncode < 0:
        try:
            return f"ended by {signal.Signals(-returncode).name}"
        except ValueError:
            return f"ended by signal {-returncode}"
    return f"exit status {returncode}, nothing said"
