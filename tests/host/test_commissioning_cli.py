"""The commissioning, cable and verify commands as a user sees them (board from its
state file: each command loads it, acts, saves it)."""

from __future__ import annotations

import json
import re
from dataclasses import fields
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.cli import main
from asictl.host.status import (
    STATUS_SCHEMA,
    MasterStatus,
    ProgramInfo,
    Timer,
    render,
    status_events,
)
from asictl.platform.display import Display

ROOT = Path(__file__).resolve().parents[2]
BLINK = ROOT / "demos" / "blink.asi"


def status(run) -> dict:
    result = run("status", "--json")
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def test_status_json_schema(run):
    """The documented schema (docs/commissioning.md): slaves by decimal address, flags."""
    assert run("download", str(BLINK), "--start").exit_code == 0
    s = status(run)
    assert set(s["slaves"]) == {"31"}
    slave = s["slaves"]["31"]
    assert set(slave) == {"inputs", "outputs", "pcd", "cdi", "pp", "pi", "lists", "errors"}
    assert slave["lists"] == ["LPS", "LDS", "LAS"] and slave["pcd"] == 0x08
    assert all(0 <= slave[k] <= 15 for k in ("inputs", "outputs", "pp", "pi"))
    assert len(s["flags"]) == 128 and all(0 <= f <= 255 for f in s["flags"])
    assert s["timers"] == [{"number": 0, "remaining_ms": s["timers"][0]["remaining_ms"],
                            "running": s["timers"][0]["running"]}]
    assert s["counters"] == [] and s["lcs"] is not None and s["los"] == []
    assert isinstance(s["hi_flags"], int)


def _documented_status_keys() -> set[str]:
    """The first column of the status table in docs/commissioning.md."""
    text = (ROOT / "docs" / "commissioning.md").read_text()
    table = text.split("## `asictl status`", 1)[1].split("| key | value |", 1)[1]
    keys: set[str] = set()
    for row in table.split("\n\n", 1)[0].splitlines()[1:]:
        keys.update(re.findall(r"`([a-z_]+)`", row.split("|")[1]))
    return keys


def test_the_status_table_names_every_key_and_no_other(run):
    """One table for every key (issue 28): the PC2 board's output, and the fields a
    gateway's status fills (the same ``MasterStatus``)."""
    documented = _documented_status_keys()
    assert run("download", str(BLINK), "--start").exit_code == 0
    shown = status(run)
    assert shown["schema"] == STATUS_SCHEMA == 1
    assert documented == set(shown)
    assert documented == {"schema"} | {f.name for f in fields(MasterStatus)}


def test_a_fresh_board_says_no_slaves_detected_yet_and_spells_out_its_letters(run):
    text = run("status").stdout
    assert "phase    start-up, configuration mode, no slaves detected yet" in text
    assert "config   no slaves detected yet" in text and ", configuration error" not in text
    assert "(c control program not running, B bus-capable," in text
    assert "o online, A auto-address enabled, w watchdog off)" in text


#: A status with nothing special in it, for the text form's tests.
BASE = dict(port="tcp://x:502 unit 1", master_name="", version_id="",
            installed_software="", ec_flags=0, phase="normal operation",
            mode="protected", config_ok=True, power_fail=False, lps=[], lds=[1],
            las=[1], missing=[], unexpected=[], wrong_profile=[],
            display=Display.from_json({"code": None, "text": "", "blinking": False,
                                       "meaning": ""}),
            control_flags=0, start_flag=False, ignore_config_errors=False,
            wait_for_set_button=False, map_counters=False, control_active=False,
            control_state="idle", stop_reason=None, program_status="not loaded",
            cycle_time_ms=0.03, max_cycle_time_ms=1.25,
            program=ProgramInfo(present=False, valid=False))


def test_cycle_times_and_timers_read_as_a_person_reads_them():
    # cycles of tens of µs read in µs, not as 0.0 ms
    assert "cycle    30 µs (max 1.25 ms)" in render(MasterStatus(**BASE))
    timers = render(MasterStatus(**BASE, timers=[Timer(1, 0, False), Timer(2, 1500, True)]))
    # a timer never started is not "elapsed"; times as a person reads them
    assert "timers   T 1: not running; T 2: running, 1.5 s left" in timers
    gateway = render(MasterStatus(**BASE, cycle_times_known=False))
    assert "cycle    n/a (the gateway does not report them)" in gateway


def test_a_board_a_debugger_holds_says_so_in_the_text_and_as_events():
    held = "halted at breakpoint line 6 by asictl dap (pid 7)"
    running = MasterStatus(**{**BASE, "control_state": "running"})
    halted = MasterStatus(**{**BASE, "control_state": "running", "held": held})
    assert f"control  {held}\n" in render(halted)
    assert "control  running\n" in render(running)
    assert status_events(running, halted) == [held]
    assert status_events(halted, running) == [
        "running again: the debugger let the program go on"]


def test_status_of_a_board_that_does_not_exist_says_so(run):
    result = run("status")
    assert result.exit_code == 0 and "a new, empty one was created" in result.stderr
    assert "new, empty" not in run("status").stderr


@pytest.mark.parametrize("command", [("start",), ("download", str(BLINK)), ("bus",)])
def test_every_board_command_says_when_it_made_a_new_board(run, command: tuple[str, ...]):
    first = run(*command)
    assert "a new, empty one was created" in first.stderr
    assert "a new, empty one was created" not in run(*command).stderr


def test_start_without_a_program_exits_1(run):
    result = run("start")
    assert result.exit_code == 1 and "no valid program" in result.stderr


def test_bus_commands(run):
    assert run("download", str(BLINK)).exit_code == 0
    assert run("bus", "plug", "16", "iiio,1").exit_code == 0
    shown = run("bus")
    assert "16  iiio,1" in shown.stdout and "31  oooo,0" in shown.stdout
    result = run("status")
    assert "asictl bus match" in result.stderr, "a config error names the fix"
    def cable_inputs() -> int:
        cable = json.loads(run("bus", "--json").stdout)
        return next(s["inputs"] for s in cable["slaves"] if s["address"] == 16)

    assert run("bus", "inputs", "16", "0xB").exit_code == 0
    assert cable_inputs() == 0xB
    assert run("bus", "inputs", "I 16.2=0", "I 16.0=0").exit_code == 0
    assert cable_inputs() == 0b1010
    result = run("bus", "match")
    assert result.exit_code == 0 and "unplugged 16" in result.stderr
    assert status(run)["config_ok"]
    assert run("bus", "unplug", "31").exit_code == 0
    assert status(run)["missing"] == [31]


def test_board_options_before_a_bus_subcommand_count(run):
    """``asictl bus --port 328h inputs ...`` acts on board 328h, as after the subcommand."""
    def slaves(port: str) -> dict[int, int]:
        cable = json.loads(run("bus", "--port", port, "show", "--json").stdout)
        return {s["address"]: s["inputs"] for s in cable["slaves"]}

    assert run("bus", "--port", "328h", "plug", "1", "iiii,0").exit_code == 0
    assert run("bus", "--port", "328h", "inputs", "1", "0b0001").exit_code == 0
    assert slaves("328h")[1] == 0b0001
    assert 1 not in slaves("300h")
    # the subcommand's own option still wins over the group's
    assert run("bus", "--port", "300h", "inputs", "--port", "328h", "1", "0").exit_code == 0
    assert slaves("328h")[1] == 0


@pytest.mark.parametrize(
    ("args", "code", "message"),
    [
        (("bus", "plug", "32", "iiio"), 2, "must be 0..31"),
        (("bus", "plug", "3", "xyz"), 2, "I/O code"),
        (("bus", "inputs", "3", "16"), 2, "must be 0..15"),
        (("bus", "inputs", "I 3.7=1"), 2, "'I 3.7': slave 0..31, data bit 0..3"),
        (("bus", "inputs", "Q 3.1=1"), 2, "'Q 3.1' is no input"),
        (("bus", "inputs", "I 3=16"), 2, "'I 3': value 16 out of range 0..15 (four data bits)"),
        (("bus", "unplug", "5"), 1, "no slave is plugged in at address 5"),
        (("bus", "inputs", "5", "1"), 1, "no slave is plugged in at address 5"),
        (("bus", "show", "--io", "devport"), 2, "emulated boards only"),
        (("bus", "match"), 1, "no program loaded"),
        (("slave", "address", "9", "10"), 1, "83A1"),
        (("slave", "address", "9", "x"), 2, "slave address"),
        (("write", "F 200.0=1"), 2, "'F 200.0': flag byte 0..127, bit 0..7"),
        (("write", "Q 3.5=1"), 2, "'Q 3.5': slave 0..31, data bit 0..3"),
        (("write", "nonsense"), 2, "expected OPERAND=VALUE, such as 'F 10.0=1'"),
        (("write", "FY 10=0x100"), 2, "'FY 10': value 256 out of range 0..255 (a byte)"),
        (("write", "FY 10=ten"), 2, "'FY 10': 'ten' is not a number"),
        (("write", "T 3=1"), 2, "'T 3' cannot be written"),
        (("write", "Q 0.1=1"), 2, "slaves 1..31 have outputs"),
        (("diag", "--set-los", "40"), 2, "must be 0..31"),
    ],
)
def test_bad_input_is_one_line_and_touches_nothing(run, args, code, message):
    before = status(run)
    result = run(*args)
    assert result.exit_code == code, result.output
    assert message in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    after = status(run)
    assert after["lps"] == before["lps"] and after["flags"] == before["flags"]


def test_commissioning_commands(run):
    assert run("bus", "plug", "0", "7,F").exit_code == 0
    assert run("mode").stderr.strip().endswith("configuration mode")
    result = run("mode", "protected")
    assert result.exit_code == 1 and "8385" in result.stderr
    assert run("slave", "address", "0", "9").exit_code == 0
    assert run("store", "configuration").exit_code == 0
    assert run("mode", "protected").exit_code == 0
    assert status(run)["lps"] == [9]
    result = run("slave", "parameter", "9", "5")
    assert result.exit_code == 0 and result.stdout.strip() == "5h"
    # nobody serves the board: the parameter does not outlive the command, and it says so
    assert "so 'asictl store parameters' then stores those, not 5h" in result.stderr
    assert run("store", "parameters").exit_code == 0
    assert status(run)["slaves"]["9"]["pp"] != 5  # what the note warned of
    assert run("slave", "command", "9", "0x10").stdout.strip() == "7h"
    result = run("store", "configuration")
    assert result.exit_code == 1 and "configuration mode" in result.stderr
    result = run("write", "FY 10=0x12")
    assert result.exit_code == 0 and "'asictl serve' keeps it running" in result.stderr
    diag = json.loads(run("diag", "--json", "--set-los", "3,9").stdout)
    assert diag["los"] == [3, 9] and diag["telegrams"] > 0
    assert "LOS      3, 9" in run("diag").stdout


def test_setup_writes_the_projected_configuration(run):
    assert run("setup", str(BLINK)).exit_code == 0
    s = status(run)
    assert s["lps"] == [31] and s["program"]["present"] is False


def test_verify(run, tmp_path):
    result = run("verify", str(BLINK))
    assert result.exit_code == 1 and "no program" in result.stdout
    assert run("download", str(BLINK)).exit_code == 0
    result = run("verify", str(BLINK))
    assert result.exit_code == 0 and "identical" in result.stdout
    changed = tmp_path / "blink.asi"
    changed.write_text(BLINK.read_text().replace("KT 500", "KT 250"))
    result = run("verify", str(changed))
    assert result.exit_code == 1 and "code ([PROGRAM])" in result.stdout
    changed.write_text(BLINK.read_text().replace("31: oooo, 0", "30: oooo, 0"))
    result = run("verify", str(changed))
    assert "configuration ([SETUP]: slaves 30, 31)" in result.stdout
    changed.write_text(BLINK.read_text().replace("auto_start: yes", "auto_start: no"))
    assert "options ([OPTIONS])" in run("verify", str(changed)).stdout
    hex_file = tmp_path / "blink.hex"
    assert CliRunner().invoke(main, ["compile", str(BLINK), "-o", str(hex_file)]).exit_code == 0
    assert run("verify", str(hex_file)).exit_code == 0



def test_verify_of_the_source_against_the_program_stored_without_it_is_identical(
    run, tmp_path: Path,
):
    """Stored from an image compiled with --no-source: the same identity, the same program;
    only where the source text is differs, which a note says."""
    bare = tmp_path / "bare.hex"
    assert CliRunner().invoke(main, ["compile", str(BLINK), "--no-source", "-o", str(bare)]
                              ).exit_code == 0
    assert run("download", str(bare)).exit_code == 0
    result = run("verify", str(BLINK))
    assert result.exit_code == 0, result.output
    assert "identical: the master holds" in result.stdout
    assert "note: only " in result.stderr and "carries the source text" in result.stderr
    # another source (a comment more) is another identity: still told apart
    other = tmp_path / "blink.asi"
    other.write_text(BLINK.read_text() + "; one comment more\n")
    different = run("verify", str(other))
    assert different.exit_code == 1 and "source text or file names only" in different.stdout


@pytest.mark.parametrize("text", ["I 1.0=1", "IB 2=90"])
def test_writing_an_input_points_to_bus_inputs_and_force(run, text: str):
    result = run("write", text)
    assert result.exit_code == 2, result.output
    assert f"asictl bus inputs '{text}' sets it on the emulated cable" in result.stderr
    assert f"asictl force '{text}' holds it for the program" in result.stderr
    flag = run("write", "FY 12=300")  # not an input: no such pointer
    assert flag.exit_code == 2 and "bus inputs" not in flag.stderr


@pytest.mark.parametrize("command", ["download", "setup", "verify"])
def test_a_missing_file_leaves_no_new_board_behind(run, tmp_path: Path, command: str):
    result = run(command, "missing.asi")
    assert result.exit_code == 2, result.output
    assert "missing.asi: cannot read: No such file or directory" in result.stderr
    assert "a new, empty one was created" not in result.stderr
    assert not (tmp_path / "state").exists()


@pytest.mark.parametrize("modes", [("--start", "--stop"), ("--stop", "--keep"),
                                   ("--start", "--keep")])
def test_download_refuses_two_start_modes(run, modes: tuple[str, str]):
    result = run("download", str(BLINK), *modes)
    assert result.exit_code == 2 and "contradict each other" in result.output
    assert run("status").exit_code == 0
    assert "no valid program" in run("start").stderr, "nothing was downloaded"


def test_bus_inputs_reads_operand_value_as_the_other_tools_do(run):
    """One reader (observe.operands): IL operands, a slave's four data bits, values in
    decimal, 0x, 0b and the IL's 0Ah; several assignments apply together, in order."""
    for address in ("16", "17"):
        assert run("bus", "plug", address, "iiii,0").exit_code == 0
    assert run("bus", "inputs", "I 16=0b0110", "I 16.3=1", "IB 16=3Ch").exit_code == 0
    cable = {s["address"]: s["inputs"] for s in json.loads(run("bus", "--json").stdout)["slaves"]}
    assert (cable[16], cable[17]) == (0xC, 0x3), "IB 16 was applied after I 16"
    assert run("bus", "inputs", "I 17.0=0", "I 16=9").exit_code == 0
    cable = {s["address"]: s["inputs"] for s in json.loads(run("bus", "--json").stdout)["slaves"]}
    assert (cable[16], cable[17]) == (9, 2)
