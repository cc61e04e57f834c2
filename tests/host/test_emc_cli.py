"""``asictl emc``: command 130 on the emulated master, on a live one, passed through to a
real board (/dev/port: a scripted board behind a file), and refused where there is none."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner
from host_helpers import ScriptedBoard, WiredDevPort

from asictl.cli import main
from asictl.host import connection
from asictl.host.live.server import background_live
from asictl.platform import pc2 as d

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"  # slave 31, four outputs
#: AS-i cycles a second with one active slave: 150 us a transaction, two a cycle.
CYCLES_PER_S = 1 / 300e-6


def counts(result) -> dict:
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def test_the_emulated_master_counts_a_test(run):
    assert run("download", str(BLINK), "--start").exit_code == 0
    good = counts(run("emc", "31", "--for", "1s", "--json"))
    # the commands that start and end the test take a few ms of polling themselves
    assert good["failures"] == 0 and abs(good["requests"] - CYCLES_PER_S) <= 15
    assert good["slaves"] == [31] and good["running"] is False
    missing = counts(run("emc", "30", "--for", "500ms", "--repetitions", "--json"))
    assert missing["requests"] == missing["failures"]
    assert abs(missing["requests"] - 2 * CYCLES_PER_S / 2) <= 30, "each one sent twice"
    checked = counts(run("emc", "31", "--expect", "1", "--for", "500ms", "--json"))
    assert checked["failures"] == checked["requests"] > 0, "slave 31 answers 0, not 1"
    long = counts(run("emc", "31", "--for", "60s", "--json"))
    # read every 5 s (the 16-bit counters hold ~20 s), each read a few ms of polling
    assert abs(long["requests"] - 60 * CYCLES_PER_S) <= 13 * 15, "beyond the 16 bits"
    text = run("emc", "31", "--for", "100ms").stdout
    assert text.startswith("300h: EMC test of slave 31 for 0.1 s: ")
    assert text.rstrip().endswith("0 failed (0.00 %)")


def test_a_test_left_running_on_a_live_board_is_ended_by_off(run):
    assert run("download", str(BLINK), "--start").exit_code == 0
    with background_live(0x300, run.state_dir, identity={"command": "test"}):
        assert counts(run("emc", "31", "--for", "100ms", "--keep", "--json"))["running"]
        status = json.loads(run("status", "--json").stdout)
        assert status["slaves"]["31"]["outputs"] == 0 or status["control_active"]
        ended = run("emc", "off")
        assert ended.exit_code == 0
        requests = int(ended.stdout.split(": ")[2].split()[0])
        assert requests > 0, "the test ran on between the commands"
        assert counts(run("emc", "off", "--json"))["requests"] == 0


@pytest.mark.parametrize("answer", [d.ACK, d.NAK])
def test_130_is_passed_through_to_a_real_board(run, tmp_path: Path, monkeypatch, answer):
    scripted = ScriptedBoard()
    scripted.dpram[d.INSTALLED_SOFTWARE : d.INSTALLED_SOFTWARE + 4] = b"cBFe"

    def emc_test_mode(board: ScriptedBoard) -> int:
        assert board.dpram[d.PROGRAM_BUFFER : d.PROGRAM_BUFFER + 6] in (
            d.emc_parameters([1, 2], 0x13, expected=0x3), d.emc_parameters([], 0)
        )
        board.dpram[d.PROGRAM_BUFFER + 8 : d.PROGRAM_BUFFER + 12] = bytes([200, 1, 7, 0])
        return answer

    scripted.answers = {130: emc_test_mode}
    path = tmp_path / "port"
    path.write_bytes(bytes(0x10000))
    monkeypatch.setattr(connection, "DevPort", lambda base: WiredDevPort(base, str(path), scripted))
    result = run("emc", "1,2", "--request", "13h", "--expect", "3", "--for", "10ms",
                 "--io", "devport", "--real-master")  # a real board: the guard's override
    if answer == d.ACK:
        assert result.exit_code == 0, result.output
        assert "456 requests, 7 failed (1.54 %)" in result.stdout
    else:
        assert result.exit_code == 1
        assert "the master has no EMC test mode (installed software byte 3 is 'e')" in (
            result.stderr
        )


def test_bad_slaves_and_a_gateway(run):
    assert run("emc", "4-2").exit_code == 2
    assert run("emc", "32").exit_code == 2
    assert run("emc", "1", "--request", "20h").exit_code == 2
    from asictl.board.board import Pc2Board
    from asictl.gateway.server import background_gateway
    from asictl.gateway.slave import GatewaySlave

    with background_gateway(GatewaySlave(Pc2Board())) as served:
        host, port = served.server.tcp_address
        url = f"tcp://{host}:{port}"
        result = CliRunner().invoke(main, ["emc", "1", "--modbus", url])
        # the gateway does report the letter E: the refusal explains it, not contradicts it
        info = json.loads(CliRunner().invoke(main, ["status", "--modbus", url, "--json"]).stdout)
    assert info["installed_software"][3] == "E"
    assert result.exit_code == 1
    assert "its software letter E is its master's (the PC2 inside has command 130)" \
        in result.stderr
    assert "no Modbus function or register that issues command 130" in result.stderr
