"""The VS Code extension's own logic and its packaging.

Its unit tests (``editors/vscode/test/unit``, Node's test runner, no VS Code download)
run here with an asictl to call, so the Testing view's scenario run is tested against
the real command. ``npx @vscode/vsce package`` must build the .vsix on a terminal
without asking anything (vsce asks y/N on a terminal when a manifest field is missing).
"""

from __future__ import annotations

import json
import os
import pty
import select
import shutil
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXTENSION = ROOT / "editors" / "vscode"


def need(path: Path | None, what: str) -> Path:
    if path is not None and path.exists():
        return path
    message = f"{what} is missing: run 'npm ci --prefix editors/vscode' (.ci/run does)"
    if os.environ.get("CI"):
        pytest.fail(message)
    pytest.skip(message)


def node() -> Path:
    found = shutil.which("node")
    return need(Path(found) if found else None, "node")


def test_the_extensions_unit_tests_pass_with_a_real_asictl(tmp_path: Path):
    wrapper = tmp_path / "asictl"
    wrapper.write_text(
        f"#!/bin/sh\nPYTHONPATH={ROOT / 'src'} exec {sys.executable} -m asictl \"$@\"\n")
    wrapper.chmod(0o755)
    result = subprocess.run(
        [str(node()), "--test", "test/unit/"], cwd=EXTENSION, capture_output=True, text=True,
        env={**os.environ, "ASICTL_TEST_COMMAND": str(wrapper)}, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "# fail 0" in result.stdout
    assert "# skipped 0" in result.stdout  # the scenario run ran


def test_the_manifest_contributes_the_debugger_and_its_settings():
    manifest = json.loads((EXTENSION / "package.json").read_text())
    contributes = manifest["contributes"]
    [debugger] = contributes["debuggers"]
    assert debugger["type"] == "asictl"
    launch = debugger["configurationAttributes"]["launch"]["properties"]
    assert {"program", "scenario", "set", "duration", "stopOnEntry"} <= set(launch)
    assert {"port", "stateDir", "program"} <= set(debugger["configurationAttributes"]["attach"]
                                                  ["properties"])
    assert contributes["breakpoints"] == [{"language": "asi"}]
    assert "asictl.path" in contributes["configuration"]["properties"]
    assert manifest["repository"]["url"]
    # the launch attributes are the adapter's: each one is read by dap/simulated.py
    source = (ROOT / "src" / "asictl" / "dap" / "simulated.py").read_text() + \
        (ROOT / "src" / "asictl" / "dap" / "adapter.py").read_text()
    for name in launch:
        assert f'"{name}"' in source, name


def test_vsce_packages_the_extension_on_a_terminal_without_a_question(tmp_path: Path):
    need(EXTENSION / "node_modules" / "@vscode" / "vsce", "@vscode/vsce")
    npx = shutil.which("npx")
    need(Path(npx) if npx else None, "npx")
    out = tmp_path / "asictl-il.vsix"
    leader, follower = pty.openpty()  # a terminal, so vsce would ask if it had a question
    process = subprocess.Popen(
        [str(npx), "--no-install", "@vscode/vsce", "package", "--out", str(out)],
        cwd=EXTENSION, stdin=follower, stdout=follower, stderr=follower, close_fds=True)
    os.close(follower)
    output = b""
    deadline = time.monotonic() + 240
    try:
        while process.poll() is None and time.monotonic() < deadline:
            ready, _, _ = select.select([leader], [], [], 0.5)
            if ready:
                try:
                    output += os.read(leader, 65536)
                except OSError:
                    break
        process.wait(timeout=max(1.0, deadline - time.monotonic()))
    finally:
        if process.poll() is None:
            process.kill()
        os.close(leader)
    text = output.decode(errors="replace")
    assert "[y/N]" not in text, text
    assert process.returncode == 0, text
    with zipfile.ZipFile(out) as vsix:
        names = vsix.namelist()
    assert "extension/extension.js" in names and "extension/lib/commands.js" in names
    assert not any(name.startswith("extension/test/") for name in names)
    assert not any("node_modules/@vscode/vsce" in name for name in names)
