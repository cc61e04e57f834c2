"""An upload writes the files a (possibly crafted) image names, all or none, and safely.

A master's EEPROM can hold any image, so the function-block file names an upload writes
come from outside. Once: a name with NUL exited 3; a 250-character name wrote the main
file and then failed; an empty name gave a misleading error; names with escape sequences
were printed raw (terminal injection) and written. And ``upload -o -`` wrote a file
named '-'. Now a name must be a plain, printable file name or nothing is written, every
file is staged before any is renamed into place, and '-' is standard output.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from asictl.board.board import Pc2Board
from asictl.build import build_file
from asictl.cli import main
from asictl.errors import UserError
from asictl.files import shown_name
from asictl.host.emulated.boards import emulated_board
from asictl.host.program_files import uploaded_files, write_files
from asictl.host.transfer import Pc2Transport, StartMode, download
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.image.eeprom import ProgramImage, pack_sources

DEMO = Path(__file__).resolve().parents[2] / "demos" / "blink.asi"
MAIN = b"[PROGRAM]\n  BE\n"


def crafted(*blocks: str) -> ProgramImage:
    """The demo's image carrying a main file and block files of the given names."""
    transport = Pc2Transport(Pc2Driver(EmulatedPort(Pc2Board())))
    image = build_file(str(DEMO), entry_points=transport.entry_points()).image
    assert image is not None
    files = [("main.asi", MAIN)] + [(name, f"; {i}\n".encode()) for i, name in enumerate(blocks)]
    return dataclasses.replace(image, source=pack_sources(files))


def store(image: ProgramImage, state: Path) -> None:
    with emulated_board(0x300, state) as board:
        download(Pc2Transport(Pc2Driver(EmulatedPort(board))), image, start=StartMode.STOP)


@pytest.mark.parametrize(
    ("name", "problem"),
    [
        ("bad\x00.fb", "with control characters in its name"),
        ("\x1b]0;pwned\x07.fb", "with control characters in its name"),
        ("\x1b[2J.fb", "with control characters in its name"),
        ("a\u202egpj.fb", "with control characters in its name"),
        ("", "with an empty name"),
        ("../up.fb", "which is not a plain file name"),
        ("..", "which is not a plain file name"),
    ],
)
def test_a_crafted_block_name_writes_nothing_and_is_printed_escaped(
    runner: CliRunner, tmp_path: Path, name: str, problem: str
):
    store(crafted("ok.fb", name), tmp_path / "state")
    out = tmp_path / "out"
    out.mkdir()
    result = runner.invoke(main, ["upload", "--state-dir", str(tmp_path / "state"),
                                  "-o", str(out / "main.asi")])
    assert result.exit_code == 1, result.output
    assert problem in result.stderr
    assert f"'{shown_name(name)}'" in result.stderr
    assert "\x1b" not in result.stderr and "\x00" not in result.stderr
    assert list(out.iterdir()) == []


def test_a_250_character_name_is_written_with_the_main_file(runner, tmp_path):
    long = "b" * 246 + ".fb"
    store(crafted(long), tmp_path / "state")
    result = runner.invoke(main, ["upload", "--state-dir", str(tmp_path / "state"),
                                  "-o", str(tmp_path / "main.asi")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / long).read_bytes() == b"; 0\n"
    assert (tmp_path / "main.asi").read_bytes() == MAIN


def test_when_one_file_cannot_be_written_none_is(tmp_path):
    image = crafted("a.fb", "b.fb")
    files = uploaded_files(image, tmp_path / "main.asi")
    (tmp_path / "b.fb").mkdir()  # a folder where a file must go: the last one fails
    with pytest.raises(UserError, match=r"b\.fb: cannot write"):
        write_files(files, overwrite=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.fb"]


def test_upload_to_stdout(runner, tmp_path):
    store(crafted(), tmp_path / "state")
    result = runner.invoke(main, ["upload", "--state-dir", str(tmp_path / "state"),
                                  "-o", "-"])
    assert result.exit_code == 0, result.output
    assert result.stdout_bytes == MAIN
    assert not Path("-").exists()


def test_upload_to_stdout_refuses_a_program_with_block_files(runner, tmp_path):
    store(crafted("a.fb"), tmp_path / "state")
    result = runner.invoke(main, ["upload", "--state-dir", str(tmp_path / "state"),
                                  "-o", "-"])
    assert result.exit_code == 2 and "give -o FILE.asi" in result.stderr
    assert result.stdout == ""


# ----- property: any name is written exactly, or refused with nothing written ------------


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.text(max_size=40).filter(lambda n: len(n.encode()) <= 255))
def test_any_block_name_is_written_as_named_or_refused_with_nothing_written(tmp_path, name):
    folder = tmp_path / "up"
    folder.mkdir(exist_ok=True)
    for old in folder.iterdir():
        old.unlink()
    image = crafted(name)
    try:
        files = uploaded_files(image, folder / "main.asi")
        write_files(files, overwrite=True)
    except UserError as exc:
        assert not name or not name.isprintable() or "/" in name or name in (".", "..") \
            or name == "main.asi", (name, exc)
        assert "\x1b" not in str(exc)
        assert [p.name for p in folder.iterdir()] == []
        return
    assert sorted(p.name for p in folder.iterdir()) == sorted({"main.asi", name})
    assert (folder / name).read_bytes() == b"; 0\n"
