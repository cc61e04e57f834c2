"""What clients change on a live board, as the others' event logs hear it
(host.live.changes): each change once, in words, with the client's name; reads never."""

from __future__ import annotations

from live_helpers import OR_PROGRAM, cli

from asictl.host.live.changes import ChangeLog
from asictl.host.live.client import open_live
from asictl.host.live.server import background_live


def test_a_download_a_force_and_inputs_are_told_once_each_and_reads_not_at_all(tmp_path):
    program = tmp_path / "or.asi"
    program.write_text(OR_PROGRAM)
    (tmp_path / "or.symbols.toml").write_text('Lamp = "Q 17.3"\n')
    with background_live(0x300, tmp_path, identity={"command": "test"}):
        watcher = open_live(tmp_path, 0x300)
        assert watcher is not None
        assert watcher.changes(None) == ([], 0)  # a new client starts from now
        for args in (["download", str(program), "--start"], ["bus", "match"],
                     ["status"], ["force", "Lamp=1"], ["bus", "inputs", "I 4.0=1"],
                     ["write", "F 3.1=1"], ["upload", "-o", str(tmp_path / "up.hex")],
                     ["unforce", "--all"]):
            assert cli(tmp_path, *args).exit_code == 0, args
        changes, after = watcher.changes(0)
        assert watcher.changes(after) == ([], after)
        watcher.close()
    texts = [change.text for change in changes]
    assert texts == [
        # the download: the [SETUP]'s slaves on the empty cable, its configuration
        # written in configuration mode, the image, the start
        "slaves of the program's [SETUP] plugged in", "command 17 (set operation mode)",
        "command 12 (set lps)", "command 8 (set permanent configuration)",
        "command 3 (set permanent parameter)", "command 17 (set operation mode)",
        "program downloaded", "program started",
        "cable matched to the projected configuration", "FORCE Q 17.3 (Lamp)=1",
        "INPUTS I 4.0=1", "FY 3=0x02", "UNFORCE all",
    ]
    assert [change.serial for change in changes] == list(range(1, len(texts) + 1))
    assert len({change.who for change in changes}) == 1
    assert changes[0].who.startswith("asictl ") and changes[0].who.endswith(")")


def test_the_log_keeps_the_latest_and_a_run_of_one_change_is_one():
    log = ChangeLog()
    for _ in range(3):
        log.note("program downloaded", "asictl download (pid 7)")
    log.note("program downloaded", "asictl download (pid 8)")
    assert [(c.serial, c.who) for c in log.since(0)] == [
        (1, "asictl download (pid 7)"), (2, "asictl download (pid 8)")]
    for n in range(500):
        log.note(f"FY {n % 128}=0x01", "asictl write (pid 9)")
    assert len(log.since(0)) == 200 and log.since(0)[-1].serial == log.serial == 502
