"""The serial settings of a gateway line: the same spellings and the same set of settings
(the gateway manual's display codes 10-83, 5.6) on the client and on ``gateway serve``."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.cli import main
from asictl.errors import UserError
from asictl.host.transports.target import check_serial_setting, parity_code, parse_target
from asictl.platform.gateway import BAUD_RATES, UNITS, serial_setting_code


def test_the_manuals_table_of_settings():
    # Anzeige 10..83: the first digit is the baud rate, the second parity and stop bits.
    assert BAUD_RATES == (1200, 2400, 4800, 9600, 19200, 28800, 38400, 57600)
    assert serial_setting_code(9600, "N", 1) == 40  # the factory setting
    assert serial_setting_code(28800, "O", 1) == 61
    assert serial_setting_code(28800, "E", 1) == 62
    assert serial_setting_code(57600, "N", 2) == 83
    assert serial_setting_code(1200, "E", 2) is None
    assert serial_setting_code(115200, "N", 1) is None
    assert (UNITS[0], UNITS[-1]) == (1, 64)


@pytest.mark.parametrize(
    ("spelling", "code"),
    [("none", "N"), ("even", "E"), ("odd", "O"), ("N", "N"), ("E", "E"), ("O", "O"),
     ("EVEN", "E"), ("Odd", "O"), ("e", "E"), ("n", "N")],
)
def test_both_parity_spellings_in_any_case(spelling, code):
    assert parity_code(spelling) == code
    assert parse_target("/dev/ttyUSB0", parity=spelling).parity == code


@pytest.mark.parametrize("bad", ["", "mark", "space", "X", "nonee"])
def test_other_parities_are_refused(bad):
    with pytest.raises(UserError, match="expected one of none, even, odd, N, E, O"):
        parity_code(bad)


def test_settings_the_gateway_lacks_are_refused():
    with pytest.raises(UserError, match="28800"):
        check_serial_setting(115200, "N", 1)
    with pytest.raises(UserError, match="two stop bits only without parity"):
        check_serial_setting(19200, "E", 2)
    with pytest.raises(UserError, match="two stop bits only without parity"):
        parse_target("/dev/ttyUSB0", baud=9600, parity="odd", stopbits=2)


@pytest.mark.parametrize("command", [["status"], ["gateway", "serve"]])
def test_cli_options_take_what_the_gateway_offers(command):
    runner = CliRunner()
    help_text = runner.invoke(main, [*command, "--help"]).output
    assert "28800" in help_text and "none|even|odd|N|E|O" in help_text
    for bad in (["--baud", "115200"], ["--parity", "mark"], ["--unit", "65"], ["--unit", "0"]):
        result = runner.invoke(main, [*command, *bad])
        assert result.exit_code == 2, (bad, result.output)
        assert bad[0] in result.output


def test_parity_with_two_stop_bits_is_refused_by_both_ends(tmp_path):
    runner = CliRunner()
    client = runner.invoke(main, ["status", "--modbus", str(tmp_path / "tty"), "--parity",
                                  "even", "--stopbits", "2"])
    assert client.exit_code == 2 and "two stop bits only without parity" in client.output
    server = runner.invoke(main, ["gateway", "serve", "--rtu", str(tmp_path / "tty"),
                                  "--parity", "E", "--stopbits", "2", "--state-dir",
                                  str(tmp_path)])
    assert server.exit_code == 2 and "two stop bits only without parity" in server.output


@pytest.fixture
def pty_pair(tmp_path: Path, socat_path: str) -> Iterator[tuple[str, str]]:
    """Two serial devices joined by socat, as a null-modem cable would join two ports."""
    socat = socat_path
    a, b = tmp_path / "a", tmp_path / "b"
    process = subprocess.Popen(
        [socat, f"pty,raw,echo=0,link={a}", f"pty,raw,echo=0,link={b}"],
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 5
    while not (a.exists() and b.exists()) and time.monotonic() < deadline:
        time.sleep(0.02)
    try:
        yield str(a), str(b)
    finally:
        process.terminate()
        process.wait(5)


@pytest.mark.parametrize("spelling", ["E", "even", "Even", "e"])
def test_the_client_takes_the_readmes_spelling(spelling, monkeypatch):
    """docs/commands.md: ``--modbus /dev/ttyX --baud 19200 --parity E``."""
    import asictl.cli.board_options as cli_board

    seen = []

    def connect(address, notify=None):
        seen.append(address)
        raise UserError("stop here")

    monkeypatch.setattr(cli_board, "open_board", connect)
    result = CliRunner().invoke(
        main, ["status", "--modbus", "/dev/ttyX", "--baud", "19200", "--parity", spelling]
    )
    assert result.exit_code == 2 and "stop here" in result.output, result.output
    assert (seen[0].baud, seen[0].parity) == (19200, "E")


@pytest.mark.parametrize("spelling", ["E", "even", "ODD", "n"])
def test_gateway_serve_takes_both_spellings(spelling, pty_pair, tmp_path):
    server = subprocess.Popen(
        [sys.executable, "-m", "asictl", "gateway", "serve", "--rtu", pty_pair[0],
         "--parity", spelling, "--state-dir", str(tmp_path)],
        stderr=subprocess.PIPE, text=True,
    )
    try:
        assert server.stderr is not None
        started = server.stderr.readline()
        assert f"9600 {parity_code(spelling)}1" in started, started
    finally:
        server.send_signal(signal.SIGINT)
        assert server.wait(timeout=10) == 0


def test_client_and_gateway_at_28800_baud_and_unit_64(pty_pair, tmp_path):
    """A whole exchange on the line at the rate the client used to lack. (Parity stays
    off here: a pty refuses pyserial's second reconfiguration with parity, which the
    client does when it sets its inter-byte time-out; a real serial port does not.)"""
    gateway_end, client_end = pty_pair
    env = {**os.environ, "ASICTL_STATE_DIR": str(tmp_path / "state")}
    server = subprocess.Popen(
        [sys.executable, "-m", "asictl", "gateway", "serve", "--rtu", gateway_end,
         "--baud", "28800", "--parity", "none", "--unit", "64"],
        stderr=subprocess.PIPE, text=True, env=env,
    )
    try:
        assert server.stderr is not None
        started = server.stderr.readline()
        assert re.search(r"rtu \S+ 28800 N1", started), started
        result = CliRunner().invoke(main, [
            "status", "--json", "--modbus", client_end, "--baud", "28800", "--parity", "N",
            "--unit", "64",
        ])
        assert result.exit_code == 0, result.output
        assert '"start_flag"' in result.stdout
    finally:
        server.send_signal(signal.SIGINT)
        assert server.wait(timeout=10) == 0
