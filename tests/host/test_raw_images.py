"""Raw images: a program that is not in asictl's format, backed up, restored and compared
byte for byte (docs/host.md "Raw images").

The programs on real masters were loaded with the vendor's tools; an upload must not call
them "no valid program", and a restore must give back the very bytes. The oracle is the
EEPROM itself, read straight from the emulated board beside the command under test.
"""

from __future__ import annotations

import json
import random
from pathlib import Path

import pytest
from click.testing import CliRunner, Result
from intelhex import IntelHex

from asictl.cli import main
from asictl.host.emulated.boards import emulated_board
from asictl.host.raw_image import LINE, from_hex, padded, to_hex, used
from asictl.host.transfer import Pc2Transport
from asictl.host.transports.driver import EmulatedPort, Pc2Driver
from asictl.host.transports.jobs import JobError, JobStatus
from asictl.platform.master import EEPROM_SIZE
from asictl.source import from_bytes


def foreign_program(seed: int = 1, size: int = 3000) -> bytes:
    """Arbitrary bytes where a vendor's program would be: not asictl's format."""
    rng = random.Random(seed)
    return bytes([0x02, 0x40, 0x00]) + bytes(rng.randrange(256) for _ in range(size - 3))


def load(state: Path, data: bytes) -> None:
    """Put ``data`` at EEPROM 0 of the emulated board in ``state``, as another tool would."""
    with emulated_board(0x300, state) as board:
        Pc2Transport(Pc2Driver(EmulatedPort(board))).write_eeprom(0, data)


def on(state: Path, *args: str) -> Result:
    """``asictl ARGS`` on the board in ``state`` (the ``run`` fixture's is its own)."""
    result = CliRunner().invoke(main, [*args, "--state-dir", str(state)])
    assert "Traceback" not in result.output
    return result


def eeprom(state: Path) -> bytes:
    with emulated_board(0x300, state) as board:
        return bytes(board._eeprom)


def test_upload_of_a_foreign_program_writes_hex_and_record(run, tmp_path: Path):
    program = foreign_program()
    load(run.state_dir, program)
    result = run("upload", "-o", "backup.hex")
    assert result.exit_code == 0, result.output
    assert "not in asictl's format" in result.stderr
    assert "0000h-0BBFh (3008 bytes); the rest of the 16 KB EEPROM is blank" in result.stderr
    hex_image = IntelHex(str(tmp_path / "backup.hex"))  # an independent HEX reader
    assert hex_image.minaddr() == 0 and hex_image.maxaddr() == 3007
    assert bytes(hex_image.tobinarray()) == eeprom(run.state_dir)[:3008]
    record = json.loads((tmp_path / "backup.json").read_text())
    assert record["image"]["bytes"] == 3008
    assert record["master"]["name"].endswith("asictl emulation")


def test_upload_to_another_name_writes_the_hex_beside_it(run, tmp_path: Path):
    load(run.state_dir, foreign_program())
    assert run("upload", "-o", "plant.asi").exit_code == 0
    assert (tmp_path / "plant.hex").exists() and not (tmp_path / "plant.asi").exists()


def test_restore_to_a_second_board_is_byte_for_byte_and_verify_agrees(run, tmp_path: Path):
    load(run.state_dir, foreign_program())
    assert run("upload", "-o", "backup.hex").exit_code == 0
    second = tmp_path / "second"
    load(second, foreign_program(seed=7, size=9000))  # something else there before
    result = on(second, "download", "backup.hex", "--raw")
    assert result.exit_code == 0, result.output
    assert "identical when read back" in result.stderr
    assert "did not load it" in result.stderr  # the emulation runs only asictl's format
    assert eeprom(second) == eeprom(run.state_dir)
    result = on(second, "verify", "backup.hex")
    assert result.exit_code == 0 and "identical" in result.stdout
    status = on(second, "status")
    assert "a program not in asictl's format (it starts with 02 40 00" in status.stdout
    assert "control  idle (no program)" in status.stdout


def test_verify_finds_a_one_byte_change(run, tmp_path: Path):
    program = foreign_program()
    load(run.state_dir, program)
    assert run("upload", "-o", "backup.hex").exit_code == 0
    load(run.state_dir, program[:0x123] + bytes([program[0x123] ^ 1]))
    result = run("verify", "backup.hex")
    assert result.exit_code == 1
    assert "different" in result.stdout and "1 byte(s) differ, first at 0123h" in result.stdout


def test_restore_setup_puts_back_the_configuration_and_flags(run, tmp_path: Path):
    load(run.state_dir, foreign_program())
    assert run("upload", "-o", "backup.hex").exit_code == 0
    record = json.loads((tmp_path / "backup.json").read_text())
    record["configuration"] = {"lps": [3, 4], "pcd": {"3": 0x71, "4": 0x08},
                               "pp": {"3": 5, "4": 0xF}}
    record["control_flags"] = 0x04
    (tmp_path / "backup.json").write_text(json.dumps(record))
    second = tmp_path / "second"
    result = on(second, "download", "backup.hex", "--raw", "--restore-setup")
    assert result.exit_code == 0, result.output
    status = json.loads(on(second, "status", "--json").stdout)
    assert status["lps"] == [3, 4]
    assert status["slaves"]["3"]["pcd"] == 0x71 and status["slaves"]["4"]["pp"] == 0xF
    assert status["control_flags"] & 0x04


def test_restore_setup_without_a_record_names_it(run, tmp_path: Path):
    (tmp_path / "lone.hex").write_text(to_hex(foreign_program()))
    result = run("download", "lone.hex", "--raw", "--restore-setup")
    assert result.exit_code == 2 and "lone.json" in result.stderr


def test_an_interrupted_raw_download_is_reported_and_repaired(run, tmp_path: Path):
    program = foreign_program()
    (tmp_path / "p.hex").write_text(to_hex(program))
    with emulated_board(0x300, run.state_dir) as board:
        transport = Pc2Transport(Pc2Driver(EmulatedPort(board)))
        transport.write_eeprom(0, b"\xff" * transport.block_size)  # the first step
        transport.write_eeprom(transport.block_size, program[transport.block_size:])
    status = run("status")
    assert "interrupted raw download" in status.stdout
    assert "'asictl download FILE.hex --raw' again repairs it" in status.stdout
    assert run("download", "p.hex", "--raw").exit_code == 0
    assert eeprom(run.state_dir) == padded(program)


def test_a_master_that_stops_answering_leaves_no_backup_file(
    run, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    load(run.state_dir, foreign_program())
    (tmp_path / "backup.hex").write_text("the previous backup\n")
    calls = 0
    real = Pc2Transport.read_eeprom

    def failing(self: Pc2Transport, address: int, size: int) -> bytes:
        nonlocal calls
        calls += 1
        if calls > 5:
            raise JobError(JobStatus.INTERFACE_ERROR, "no answer")
        return real(self, address, size)

    monkeypatch.setattr(Pc2Transport, "read_eeprom", failing)
    result = run("upload", "-o", "backup.hex", "--overwrite")
    assert result.exit_code == 1 and "no answer" in result.stderr
    assert (tmp_path / "backup.hex").read_text() == "the previous backup\n"
    assert not (tmp_path / "backup.json").exists()


@pytest.mark.parametrize(
    ("records", "line", "problem"),
    [
        ([":020000040001F9"], 1, "beyond the 16 KB EEPROM"),
        ([":10000000" + "00" * 16 + "F0", ":10002000" + "00" * 16 + "D0"], 2,
         "a gap: no bytes for 0010h-001Fh"),
        ([":10000000" + "00" * 16 + "F0", ":10000000" + "00" * 16 + "F0"], 2,
         "given twice"),
        ([":103FF800" + "00" * 16 + "B9"], 1, "outside the 16 KB EEPROM"),
        ([":10000000" + "00" * 16 + "F1"], 1, "checksum"),
    ],
)
def test_a_bad_raw_hex_is_refused_with_its_line(run, tmp_path: Path, records, line, problem):
    (tmp_path / "bad.hex").write_text("\n".join([*records, ":00000001FF"]) + "\n")
    result = run("download", "bad.hex", "--raw")
    assert result.exit_code == 2
    assert f"bad.hex:{line}:1: error: " in result.stderr and "[E603]" in result.stderr
    assert problem in result.stderr


def test_a_hex_larger_than_the_eeprom_is_refused(run, tmp_path: Path):
    (tmp_path / "big.hex").write_text(to_hex(bytes(EEPROM_SIZE + LINE)))
    result = run("download", "big.hex", "--raw")
    assert result.exit_code == 2 and "outside the 16 KB EEPROM" in result.stderr


def test_hex_round_trip_keeps_every_byte():
    for size in (0, 1, 15, 16, 17, 4000, EEPROM_SIZE):
        data = foreign_program(size=max(size, 3))[:size]
        assert from_hex(from_bytes("x.hex", to_hex(data).encode())) == data


def test_used_stops_at_the_last_non_blank_line():
    assert used(b"\x01" + b"\xff" * 100) == b"\x01" + b"\xff" * 15
    assert used(b"\xff" * 64) == b""
    assert len(used(bytes(EEPROM_SIZE))) == EEPROM_SIZE


def test_the_same_through_dev_port(run, tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """``--io devport`` takes the same path: boards behind the register interface, one a
    look-alike that does not say it is asictl's emulation (so the guard stops there)."""
    from host_helpers import isa_bus

    from asictl.board.board import Pc2Board
    from asictl.host import connection, search

    first = Pc2Board()
    Pc2Transport(Pc2Driver(EmulatedPort(first))).write_eeprom(0, foreign_program())
    second = Pc2Board()
    monkeypatch.setattr("asictl.board.images.MASTER_VERSION", b"V2.14".ljust(16, b"\0"))
    look_alike = Pc2Board()
    installed = {0x300: first, 0x304: second, 0x308: look_alike}
    for board in installed.values():
        board.advance(100)
    bus = isa_bus(tmp_path / "port", installed)
    monkeypatch.setattr(search, "DevPort", bus)
    monkeypatch.setattr(connection, "DevPort", bus)
    dev = ("--io", "devport", "--port")
    assert run("upload", "-o", "b.hex", *dev, "300h").exit_code == 0
    restored = run("download", "b.hex", "--raw", *dev, "304h")
    assert restored.exit_code == 0, restored.output
    assert bytes(second._eeprom) == bytes(first._eeprom)
    assert run("verify", "b.hex", *dev, "304h").exit_code == 0
    refused = run("download", "b.hex", "--raw", *dev, "308h")
    assert refused.exit_code == 1 and "give --real-master" in refused.stderr
    assert run("download", "b.hex", "--raw", "--real-master", *dev, "308h").exit_code == 0
    assert bytes(look_alike._eeprom) == bytes(first._eeprom)
    probed = run("probe", "-o", "p.json", *dev, "308h")
    assert probed.exit_code == 0, probed.output
    assert json.loads((tmp_path / "p.json").read_text())["identification"][
        "asictl_emulation"] is False


def test_verify_of_an_asictl_program_against_a_foreign_one_compares_bytes(run):
    load(run.state_dir, foreign_program())
    result = run("verify", str(Path(__file__).resolve().parents[2] / "demos" / "blink.asi"))
    assert result.exit_code == 1
    assert "different" in result.stdout and "first at 0000h" in result.stdout


class Interrupted(Exception):
    pass


class FailingTransport(Pc2Transport):
    """The PC2 transport with a gateway's block size if asked, failing at write ``n``."""

    def __init__(self, driver: Pc2Driver, block_size: int, fail_at: int | None) -> None:
        super().__init__(driver)
        self.block_size = block_size
        self.fail_at = fail_at
        self.writes = 0

    def write_eeprom(self, address: int, data: bytes) -> None:
        self.writes += 1
        if self.writes == self.fail_at:
            raise Interrupted(address)
        super().write_eeprom(address, data)


@pytest.mark.parametrize("block_size", [16, 240])
@pytest.mark.parametrize("fail_at", [2, 3, 40, "last"])
def test_a_raw_download_interrupted_at_any_block_is_reported_and_repaired(
    block_size: int, fail_at: int | str
):
    """Over a program that was there (as a restore after a repair finds one): the
    interrupted EEPROM starts blank and holds bytes further on, whatever the block size
    (a gateway's 16, the PC2's 240) and wherever it stopped, even at the last write."""
    from asictl.board.board import Pc2Board
    from asictl.host.raw_image import download_raw
    from asictl.host.status import read_program

    program = foreign_program()
    counting = FailingTransport(Pc2Driver(EmulatedPort(Pc2Board())), block_size, None)
    download_raw(counting, program)
    board = Pc2Board()
    driver = Pc2Driver(EmulatedPort(board))
    Pc2Transport(driver).write_eeprom(0, foreign_program(seed=9, size=9000))
    transport = FailingTransport(
        driver, block_size, counting.writes if fail_at == "last" else int(fail_at))
    with pytest.raises(Interrupted):
        download_raw(transport, program)
    problem = read_program(FailingTransport(driver, block_size, None)).info.problem
    assert problem is not None and "interrupted raw download" in problem
    download_raw(FailingTransport(driver, block_size, None), program)
    assert bytes(board._eeprom) == padded(program)
