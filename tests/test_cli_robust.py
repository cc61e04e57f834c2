"""Odd command-line values and damaged files end in a plain message, never exit 3.

Each test is a reproducer that once ended with an internal error or did something
silently wrong: a port written '²' or with 5000 digits, a deeply nested JSON state
file, a folder ``check`` could not read and skipped without a word.
"""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st

import asictl.cli.check  # noqa: F401 - loaded before a test forks, so the child has it
from asictl.cli import main
from asictl.errors import UserError
from asictl.host.transports.target import parse_target, port_number

BAD_PORTS = ["²", "9" * 5000, "-1", "65536", "", " 80", "0x50", "٣"]


@pytest.mark.parametrize("port", BAD_PORTS)
def test_gateway_tcp_with_a_bad_port_is_a_usage_error(runner: CliRunner, port: str):
    result = runner.invoke(main, ["gateway", "serve", "--tcp", f"127.0.0.1:{port}"])
    assert result.exit_code == 2, result.output
    assert "expected HOST:PORT" in result.stderr and len(result.stderr) < 200


@pytest.mark.parametrize("port", [*BAD_PORTS, "0"])
def test_modbus_url_with_a_bad_port_is_a_usage_error(port: str):
    with pytest.raises(UserError, match="expected tcp://HOST"):
        parse_target(f"tcp://127.0.0.1:{port}")


@given(st.text(max_size=8))
def test_port_number_takes_exactly_ascii_numbers_up_to_65535(text: str):
    number = port_number(text)
    if text.isascii() and text.isdigit() and len(text) <= 5 and int(text) <= 65535:
        assert number == int(text)
    else:
        assert number is None


def test_a_deeply_nested_state_file_is_corrupt_exit_2(runner: CliRunner, tmp_path: Path):
    (tmp_path / "pc2-300h.json").write_text("[" * 100_000 + "]" * 100_000)
    result = runner.invoke(main, ["status", "--state-dir", str(tmp_path)])
    assert result.exit_code == 2, result.output
    assert "state is corrupt" in result.stderr


# ----- check DIR with a folder it cannot read ---------------------------------------------


def _check_as_nobody(directory: Path) -> tuple[int, str]:
    """``asictl check DIR`` in a forked child without root's right to read anything."""
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child
        code = 99
        try:
            os.setgid(65534)
            os.setuid(65534)
            result = CliRunner().invoke(main, ["check", str(directory)])
            os.write(write_end, result.stderr.encode())
            code = result.exit_code
        finally:
            os._exit(code)
    os.close(write_end)
    with os.fdopen(read_end, "rb") as stream:
        output = stream.read().decode()
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status), output


def test_check_dir_reports_a_folder_it_cannot_read():
    top = Path(tempfile.mkdtemp(prefix="asictl-check-"))
    try:
        top.chmod(0o755)
        (top / "good.asi").write_text("[PROGRAM]\n  BE\n")
        hidden = top / "locked"
        hidden.mkdir()
        (hidden / "missed.asi").write_text("[PROGRAM]\n  BE\n")
        hidden.chmod(0)
        if os.geteuid() == 0:
            code, stderr = _check_as_nobody(top)
        else:
            result = CliRunner().invoke(main, ["check", str(top)])
            code, stderr = result.exit_code, result.stderr
        assert code == 2, stderr
        assert f"asictl: error: {hidden}: cannot read: Permission denied" in stderr
        assert "checked 1 file: 0 errors, 0 warnings, 1 unreadable" in stderr
    finally:
        hidden.chmod(stat.S_IRWXU)
        for path in sorted(top.rglob("*"), reverse=True):
            path.rmdir() if path.is_dir() else path.unlink()
        top.rmdir()


def test_check_dir_of_readable_folders_finds_every_asi_file(runner, tmp_path):
    for name in ("a.asi", "sub/b.ASI", "sub/deeper/c.asi", "sub/not.txt"):
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text("[PROGRAM]\n  BE\n")
    result = runner.invoke(main, ["check", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "checked 3 files" in result.stderr
