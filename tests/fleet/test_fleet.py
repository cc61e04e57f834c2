"""``fleet backup|verify|status`` on a fleet of emulated gateways on loopback ports, and on
PC2 boards in state directories; the archive's git history against what changed."""

from __future__ import annotations

import json
import os
import pty
import re
import shutil
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner, Result
from served_gateway import serve_gateways

from asictl.cli import main

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"
EDGE = ROOT / "demos" / "edge.asi"
GATEWAYS = 12


def asictl(*args: str, code: int = 0) -> Result:
    result = CliRunner().invoke(main, list(args))
    assert result.exit_code == code, (args, result.output, result.stderr)
    return result


def git(archive: Path, *args: str) -> str:
    return subprocess.run(
        ["git", "-C", str(archive), *args], capture_output=True, text=True, check=True
    ).stdout


def board_with(program: Path, state: Path) -> Path:
    """A state directory whose board 300h runs ``program``."""
    state.mkdir(mode=0o700)
    asictl("download", str(program), "--start", "--state-dir", str(state))
    return state


@pytest.fixture(scope="module")
def gateways(tmp_path_factory: pytest.TempPathFactory) -> Iterator[list[int]]:
    """Twelve gateways, each in front of its own board running blink.asi."""
    root = tmp_path_factory.mktemp("fleet")
    first = board_with(BLINK, root / "board-00")
    states = [first]
    for n in range(1, GATEWAYS):
        states.append(root / f"board-{n:02}")
        states[-1].mkdir(mode=0o700)
        shutil.copy(first / "pc2-300h.json", states[-1])
    with serve_gateways(states) as ports:
        yield ports


def plant(path: Path, ports: list[int], extra: str = "") -> Path:
    path.write_text(
        "[defaults]\ntimeout = \"2s\"\n\n" + "".join(
            f'[masters.gw-{n:02}]\nmodbus = "tcp://127.0.0.1:{port}"\nline = "line-{n % 2}"\n\n'
            for n, port in enumerate(ports)
        ) + extra
    )
    return path


def test_twelve_gateways_one_commit_then_exactly_the_changed_one(
    gateways: list[int], tmp_path: Path
):
    inventory = plant(tmp_path / "plant.toml", gateways)
    archive = tmp_path / "archive"
    first = json.loads(asictl("fleet", "backup", str(inventory), "--into", str(archive),
                              "--format", "json").stdout)
    assert first["failed"] == [] and len(first["changed"]) == GATEWAYS
    assert git(archive, "rev-list", "--count", "HEAD").strip() == "1"
    files = git(archive, "show", "--name-only", "--format=", "HEAD").split()
    assert {f.split("/")[0] for f in files} == {f"gw-{n:02}" for n in range(GATEWAYS)}
    assert "gw-05/blink.asi" in files and "gw-05/image.hex" in files
    identity = json.loads((archive / "gw-05" / "identity.json").read_text())
    assert identity["program"]["files"] == ["blink.asi"]
    assert (archive / "gw-05" / "blink.asi").read_bytes() == BLINK.read_bytes()

    verified = asictl("fleet", "verify", str(inventory), "--against", str(archive))
    assert verified.stdout.endswith(f"{GATEWAYS} of {GATEWAYS} masters run what {archive} holds\n")

    asictl("download", str(EDGE), "--modbus", f"tcp://127.0.0.1:{gateways[7]}", "--start")
    drift = asictl("fleet", "verify", str(inventory), "--against", str(archive),
                   "--format", "json", code=1)
    report = json.loads(drift.stdout)
    assert report["drift"] == ["gw-07"]
    gw07 = report["masters"][7]
    assert gw07["result"] == "different" and "code ([PROGRAM])" in gw07["differences"]
    assert gw07["networks"] and all("network" in line for line in gw07["networks"])
    assert all(m["result"] == "identical" for m in report["masters"] if m["master"] != "gw-07")

    second = asictl("fleet", "backup", str(inventory), "--into", str(archive))
    assert "commit" in second.stdout and "(1 changed)" in second.stdout
    assert git(archive, "rev-list", "--count", "HEAD").strip() == "2"
    changed = git(archive, "show", "--name-status", "--format=%s%n%b", "HEAD")
    assert changed.startswith("fleet backup: 1 master changed (gw-07)\n")
    assert "gw-07: program 20d70c72b6d2 -> " in changed
    paths = [line.split("\t")[1] for line in changed.splitlines() if "\t" in line]
    assert sorted(paths) == [
        "gw-07/blink.asi", "gw-07/edge.asi", "gw-07/identity.json", "gw-07/image.hex",
        "gw-07/status.json",
    ]
    assert not (archive / "gw-07" / "blink.asi").exists()

    third = asictl("fleet", "backup", str(inventory), "--into", str(archive), "--line", "line-1")
    assert third.stdout.endswith("6 of 6 masters backed up; nothing changed, no commit\n")
    assert git(archive, "rev-list", "--count", "HEAD").strip() == "2"
    assert asictl("fleet", "verify", str(inventory), "--against", str(archive)).stdout.endswith(
        f"{GATEWAYS} of {GATEWAYS} masters run what {archive} holds\n"
    )

    status = asictl("fleet", "status", str(inventory)).stdout.splitlines()
    assert len(status) == GATEWAYS
    assert status[0].startswith(f"gw-00  tcp://127.0.0.1:{gateways[0]} unit 1: control program")
    assert status[7].endswith("program 217f990c9624") and status[0].endswith("program 20d70c72b6d2")


def test_one_master_that_does_not_answer_stops_no_other(tmp_path: Path):
    """A PC2 board in a state directory, a gateway port nobody serves, a board that is
    not there (and must not be made): the first is archived, the others fail, exit 1."""
    board_with(BLINK, tmp_path / "boards")
    silent = socket.create_server(("127.0.0.1", 0))  # accepts, never answers
    inventory = tmp_path / "plant.toml"
    inventory.write_text(
        '[masters.pc-1]\nport = "300h"\nstate_dir = "boards"\n\n'
        '[masters.gone]\nmodbus = "tcp://127.0.0.1:9"\ntimeout = "200ms"\nretries = 0\n\n'
        '[masters.pc-2]\nport = "304h"\nstate_dir = "boards"\n\n'
        f'[masters.silent]\nmodbus = "tcp://127.0.0.1:{silent.getsockname()[1]}"\n'
        "timeout = \"200ms\"\nretries = 1\nattempts = 1\n"
    )
    archive = tmp_path / "archive"
    archive.mkdir()
    subprocess.run(["git", "init", "-q", str(archive)], check=True)
    (archive / "README").write_text("the plant's archive\n")
    git(archive, "add", "README")  # staged by the user: not the backup's to commit
    result = asictl("fleet", "backup", str(inventory), "--into", str(archive), code=1)
    assert git(archive, "diff", "--cached", "--name-only").split() == ["README"]
    lines = result.stdout.splitlines()
    assert lines[1].split()[:4] == ["pc-1", "port", "300h", "changed"]
    assert lines[2].split()[:5] == ["gone", "tcp://127.0.0.1:9", "unit", "1", "FAILED"]
    assert lines[2].split()[-3] == "2"  # tries: the default attempts
    assert lines[3].split()[:4] == ["pc-2", "port", "304h", "FAILED"]
    assert f"pc-2: no emulated board 304h in {tmp_path / 'boards'}" in result.stderr
    assert not (tmp_path / "boards" / "pc2-304h.json").exists()
    assert lines[4].split()[0] == "silent" and lines[4].split()[-5:-3] == ["FAILED", "-"]
    assert lines[4].split()[-3] == "1"  # its own attempts
    silent_error = next(x for x in result.stderr.splitlines() if x.startswith("silent: "))
    assert "no answer" in silent_error or "time" in silent_error, silent_error
    assert lines[-1] == f"{archive}: 1 of 4 masters backed up; commit " + git(
        archive, "rev-parse", "HEAD")[:12] + " (1 changed)"
    message = git(archive, "log", "-1", "--format=%B")
    assert "not backed up:\ngone: cannot open the Modbus connection" in message
    assert git(archive, "log", "-1", "--format=%an <%ae>").strip() == (
        "asictl fleet backup <asictl@localhost>"
    )

    verify = asictl("fleet", "verify", str(inventory), "--against", str(archive), code=1)
    assert verify.stdout.splitlines() == [
        "pc-1: identical (20d70c72b6d28daa44489603394639cf)",
        *[line for line in verify.stdout.splitlines() if line.startswith("gone: unreachable: ")],
        f"pc-2: unreachable: no emulated board 304h in {tmp_path / 'boards'}",
        *[line for line in verify.stdout.splitlines() if line.startswith("silent: unreachable")],
        f"1 of 4 masters run what {archive} holds; not: gone, pc-2, silent",
    ]

    status = json.loads(asictl("fleet", "status", str(inventory), "--format", "json",
                               code=1).stdout)["masters"]
    assert [(m["master"], m["answered"]) for m in status] == [
        ("pc-1", True), ("gone", False), ("pc-2", False), ("silent", False)
    ]
    assert status[0]["program"] == "20d70c72b6d28daa44489603394639cf"
    assert status[0]["summary"] == "control program running"
    silent.close()


def test_a_folder_that_is_no_archive_is_not_taken_over(tmp_path: Path):
    board_with(BLINK, tmp_path / "boards")
    inventory = tmp_path / "plant.toml"
    inventory.write_text('[masters.pc-1]\nport = "300h"\nstate_dir = "boards"\n')
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    result = asictl("fleet", "backup", str(inventory), "--into", str(tmp_path / "other"), code=2)
    assert "a folder with files in it and no git repository is not an archive" in result.stderr
    assert not (tmp_path / "other" / ".git").exists()


def test_a_progress_line_on_a_terminal_only(tmp_path: Path):
    """Standard error a terminal: one line rewritten per master as each finishes, and
    cleared before the table; not a terminal (the tests above): no progress at all."""
    board_with(BLINK, tmp_path / "boards")
    board_with(BLINK, tmp_path / "more")
    inventory = tmp_path / "plant.toml"
    inventory.write_text('[masters.pc-1]\nport = "300h"\nstate_dir = "boards"\n\n'
                         '[masters.pc-2]\nport = "300h"\nstate_dir = "more"\n')
    main_fd, terminal = pty.openpty()
    result = subprocess.run(
        [sys.executable, "-m", "asictl", "fleet", "backup", str(inventory), "--into",
         str(tmp_path / "archive")], stdout=subprocess.PIPE, stderr=terminal, timeout=60,
    )
    os.close(terminal)
    shown = b""
    while True:
        try:
            chunk = os.read(main_fd, 4096)
        except OSError:  # the terminal's other end is closed: all is read
            break
        if not chunk:
            break
        shown += chunk
    os.close(main_fd)
    assert result.returncode == 0
    text = shown.decode()
    assert re.search(r"^\rbackup 1/2: pc-[12] ok", text)
    assert re.search(r"\rbackup 2/2: pc-[12] ok", text)
    assert text.endswith("\r")  # the line cleared: the table starts at the margin
    assert b"backup 1/2" not in result.stdout and result.stdout.startswith(b"master ")


def test_a_different_program_is_reported_network_by_network(tmp_path: Path):
    """The archive holds blink.asi; the master runs it with the second network changed
    (the output inverted the other way): verify names that network alone."""
    from asictl.build import build_file
    from asictl.fleet.compare import network_changes

    blink = (ROOT / "demos" / "blink.asi").read_text()
    changed = tmp_path / "blink.asi"
    changed.write_text(blink.replace("        AN  Q 31.0", "        A   Q 31.0"))
    archived, running = build_file(ROOT / "demos" / "blink.asi").image, build_file(changed).image
    assert archived is not None and running is not None
    lines = network_changes(archived, running)
    assert len(lines) == 1 and lines[0].startswith("changed blink.asi network 2"), lines
    assert network_changes(archived, archived) == ()
    bare = build_file(changed, with_source=False).image
    assert bare is not None and network_changes(archived, bare) == ()

