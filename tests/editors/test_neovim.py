"""The Neovim set-ups of docs/editors.md, verbatim, in Debian's neovim run headless.

The snippet for the installed version (0.11+, 0.8-0.10, or the one line for 0.7) is the
init file; with an IL file open the language server's diagnostics must arrive; then the
nvim-dap snippet (with a stand-in for the nvim-dap plugin, which Debian does not ship)
must start ``asictl dap`` so that it answers. Every snippet must at least parse in the
installed Neovim's Lua, and docs/editors.md must show each one as it is in
editors/neovim/.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SNIPPETS = ROOT / "editors" / "neovim"
DOC = ROOT / "docs" / "editors.md"
#: the snippet for each version range, newest first: (lowest version, file)
BY_VERSION = [((0, 11), "asictl.lua"), ((0, 8), "asictl-0.8.lua"), ((0, 7), "asictl-0.7.lua")]
FAKE_DAP = ("lua package.preload.dap = function() return { adapters = {}, configurations = {}, "
            "session = function() end } end")


def nvim() -> str:
    path = shutil.which("nvim")
    if path:
        return path
    message = "nvim is missing (apt-get install -y neovim): the Neovim set-up tests"
    if os.environ.get("CI"):
        pytest.fail(message)
    pytest.skip(message)


def version(command: str) -> tuple[int, int]:
    first = subprocess.run([command, "--version"], capture_output=True, text=True).stdout
    match = re.search(r"NVIM v(\d+)\.(\d+)", first)
    assert match, first
    return int(match[1]), int(match[2])


def snippet_for(found: tuple[int, int]) -> Path:
    return next(SNIPPETS / name for lowest, name in BY_VERSION if found >= lowest)


@pytest.mark.parametrize("name", sorted(p.name for p in SNIPPETS.glob("*.lua")))
def test_each_snippet_parses_and_is_in_the_doc_verbatim(name: str):
    text = (SNIPPETS / name).read_text()
    assert f"```lua\n{text}```" in DOC.read_text(), f"docs/editors.md does not show {name}"
    check = (f"lua local f, e = loadfile('{SNIPPETS / name}') "
             "if not f then io.stderr:write(e) vim.cmd('cq') end")
    result = subprocess.run([nvim(), "--headless", "-n", "-i", "NONE", "-u", "NONE",
                             "-c", check, "-c", "qa!"], capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 0, result.stderr


def test_the_snippet_for_this_neovim_gets_diagnostics_and_starts_the_adapter(tmp_path: Path):
    command = nvim()
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    wrapper = bin_dir / "asictl"  # the snippets run "asictl" from the PATH, as written
    wrapper.write_text(f"#!/bin/sh\nexec {sys.executable} -m asictl \"$@\"\n")
    wrapper.chmod(0o755)
    program = tmp_path / "main.asi"
    program.write_text("[SETUP]\n1: iiii, 0\n[PROGRAM]\n        A   I 1.9\n        =   F 0.0\n")
    out = tmp_path / "seen.txt"
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}",
           "PYTHONPATH": str(ROOT / "src"), "ASICTL_NVIM_OUT": str(out),
           "HOME": str(tmp_path), "XDG_STATE_HOME": str(tmp_path / "state")}
    snippet = snippet_for(version(command))
    result = subprocess.run(
        [command, "--headless", "-n", "-i", "NONE", "--cmd", FAKE_DAP, "-u", str(snippet),
         str(program), "-c", f"luafile {SNIPPETS / 'asictl-dap.lua'}",
         "-c", f"luafile {ROOT / 'tests' / 'editors' / 'nvim_check.lua'}"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=180)
    assert out.exists(), result.stdout + result.stderr
    seen = out.read_text().splitlines()
    assert seen[0] == "diagnostics true", seen
    assert "4: data bit 9 out of range 0..3" in seen  # A   I 1.9, as asictl check says
    assert "adapter true" in seen
    assert "configurations 3" in seen
