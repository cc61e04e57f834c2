"""Outputs never replace a command's inputs, and never replace a device or FIFO.

Once, ``sim --csv/--vcd/--plot``, ``asm -o/--listing``, ``disasm -o`` and ``test --junit``
silently overwrote their own input, and as root ``-o /dev/null`` turned /dev/null into a
regular file. ``asictl.files`` now holds the rule for every command: an input is refused,
a character device or FIFO is written as a stream, a regular file replaced atomically.
"""

from __future__ import annotations

import os
import shutil
import stat
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from asictl.cli import main
from asictl.errors import UserError
from asictl.files import write_atomic, write_output

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "tests" / "scenarios"
A51 = "\torg 0\n\tljmp 3Bh\n"
HEX = ":0300000002003BC0\n:00000001FF\n"


@pytest.fixture
def blink(tmp_path: Path) -> tuple[Path, Path]:
    for name in ("blink.asi", "blink.scenario.toml"):
        shutil.copy(SCENARIOS / name, tmp_path / name)
    return tmp_path / "blink.asi", tmp_path / "blink.scenario.toml"


def refused(runner: CliRunner, args: list[str], victim: Path) -> None:
    before = victim.read_bytes()
    result = runner.invoke(main, args)
    assert result.exit_code == 2, result.output
    assert "is an input of this command" in result.stderr
    assert victim.read_bytes() == before


@pytest.mark.parametrize("option", ["--csv", "--vcd", "--plot"])
@pytest.mark.parametrize("which", ["program", "scenario"])
def test_sim_never_writes_over_its_program_or_scenario(runner, blink, option, which):
    program, scenario = blink
    victim = program if which == "program" else scenario
    refused(runner, ["sim", str(program), "--scenario", str(scenario), option, str(victim)],
            victim)


def test_test_junit_never_writes_over_a_scenario_or_program(runner, blink):
    program, scenario = blink
    for victim in (scenario, program):
        refused(runner, ["test", str(scenario.parent), "--junit", str(victim)], victim)


@pytest.mark.parametrize("option", ["-o", "--listing", "--symbols"])
def test_asm_never_writes_over_its_source_or_an_include(runner, tmp_path, option):
    source, include = tmp_path / "p.a51", tmp_path / "defs.inc"
    include.write_text("five equ 5\n")
    source.write_text("$include(defs.inc)\n" + A51 + "\tdb five\n")
    for victim in (source, include):
        refused(runner, ["asm", str(source), "-o", str(tmp_path / "p.hex"), option, str(victim)]
                if option != "-o" else ["asm", str(source), "-o", str(victim)], victim)


def test_asm_of_a_hex_named_source_does_not_replace_it(runner, tmp_path):
    source = tmp_path / "odd.hex"
    source.write_text(A51)
    refused(runner, ["asm", str(source)], source)


def test_disasm_never_writes_over_its_image_not_even_through_a_hard_link(runner, tmp_path):
    image = tmp_path / "p.hex"
    image.write_text(HEX)
    os.link(image, tmp_path / "alias.a51")
    refused(runner, ["disasm", str(image), "-o", str(image)], image)
    refused(runner, ["disasm", str(image), "-o", str(tmp_path / "alias.a51")], image)


# ----- devices and FIFOs --------------------------------------------------------------


@pytest.fixture
def device(tmp_path: Path) -> Iterator[Path]:
    """A character device to write to: a /dev/null of our own where we may make one
    (as root, where the bug replaced devices), else /dev/null itself."""
    node = tmp_path / "null"
    try:
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    except PermissionError:
        node = Path("/dev/null")
    yield node
    assert stat.S_ISCHR(os.stat(node).st_mode), f"{node} is no longer a device"


def test_every_command_writes_to_a_device_without_replacing_it(runner, tmp_path, blink, device):
    program, scenario = blink
    source, image = tmp_path / "p.a51", tmp_path / "p.hex"
    source.write_text(A51)
    image.write_text(HEX)
    commands = [
        ["asm", str(source), "-o", str(device), "--listing", str(device)],
        ["disasm", str(image), "-o", str(device)],
        ["compile", str(program), "-o", str(device)],
        ["compile", str(program), "-o", str(tmp_path / "b.hex"), "--listing", str(device)],
        ["sim", str(program), "--scenario", str(scenario), "--csv", str(device),
         "--vcd", str(device)],
        ["test", str(scenario), "--junit", str(device)],
    ]
    for args in commands:
        result = runner.invoke(main, args)
        assert result.exit_code == 0, (args, result.output)
        assert stat.S_ISCHR(os.stat(device).st_mode), args


def test_a_fifo_is_written_as_a_stream(tmp_path):
    fifo = tmp_path / "out"
    os.mkfifo(fifo)
    received = bytearray()
    written = threading.Event()
    fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)  # the reader is there before the writer

    def read() -> None:
        while True:
            try:
                chunk = os.read(fd, 65536)
            except BlockingIOError:
                time.sleep(0.001)
                continue
            if chunk:
                received.extend(chunk)
            elif written.is_set():  # end of file after the writer closed
                return
            else:
                time.sleep(0.001)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    data = b"x" * 300_000  # more than a pipe holds: the writer must wait for the reader
    write_atomic(fifo, data)
    written.set()
    reader.join(10)
    os.close(fd)
    assert bytes(received) == data
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)


def test_a_fifo_nobody_reads_is_an_error_not_a_hang(tmp_path):
    fifo = tmp_path / "out"
    os.mkfifo(fifo)
    with pytest.raises(UserError, match="no process reads from it"):
        write_atomic(fifo, "data")


def test_a_symbolic_link_keeps_pointing_at_the_replaced_file(tmp_path):
    real = tmp_path / "real.hex"
    real.write_text("old")
    link = tmp_path / "link.hex"
    link.symlink_to(real)
    write_atomic(link, "new")
    assert link.is_symlink() and real.read_text() == "new"


def test_a_directory_is_not_replaced(tmp_path):
    with pytest.raises(UserError, match="it is a directory"):
        write_atomic(tmp_path, "x")


# ----- property: whatever the target, the rule holds ------------------------------------

KINDS = ["new", "regular", "input", "hard link to input", "symlink to input",
         "symlink to other", "device"]


@settings(max_examples=100, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(KINDS), data=st.one_of(st.binary(max_size=200),
                                                   st.text(max_size=200)))
def test_write_output_replaces_only_regular_files_that_are_not_inputs(tmp_path, device, kind,
                                                                      data):
    work = tmp_path / "work"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir()
    source, other = work / "in.asi", work / "other.txt"
    source.write_bytes(b"input")
    other.write_bytes(b"other")
    target = {
        "new": work / "out.hex", "regular": other, "input": source,
        "device": device,
    }.get(kind, work / "link")
    if kind == "hard link to input":
        os.link(source, target)
    elif kind == "symlink to input":
        target.symlink_to(source)
    elif kind == "symlink to other":
        target.symlink_to(other)
    expected = data if isinstance(data, bytes) else data.encode()
    if kind in ("input", "hard link to input", "symlink to input"):
        with pytest.raises(UserError, match="is an input of this command"):
            write_output(target, data, inputs=[source])
    else:
        write_output(target, data, inputs=[source])
        if kind == "device":
            assert stat.S_ISCHR(os.stat(target).st_mode)
        else:
            assert target.read_bytes() == expected
            assert stat.S_ISREG(os.stat(target).st_mode)
    assert source.read_bytes() == b"input"
    assert target.is_symlink() == kind.startswith("symlink")
    assert sorted(p.name for p in work.iterdir() if p.name.endswith(".tmp")) == []


@pytest.mark.parametrize("redirect", [">&-", ">/dev/full"])
def test_an_output_to_a_closed_or_full_standard_output_is_an_error(tmp_path: Path, redirect):
    """``compile -o -`` with nowhere to write exits non-zero and says so (it exited 0)."""
    import subprocess
    import sys

    demo = Path(__file__).resolve().parents[1] / "demos" / "blink.asi"
    shell = f"{sys.executable} -m asictl compile {demo} -o - {redirect}"
    done = subprocess.run(["bash", "-c", shell], capture_output=True, text=True)
    assert done.returncode == 2, done.stderr
    assert "standard output: cannot write" in done.stderr and "internal error" not in done.stderr
