"""The layout the pipeline asks for: each step in one place, nothing importing upwards."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "asictl"


def modules_after_import(module: str) -> list[str]:
    """The asictl modules and lark loaded by importing ``module`` in a fresh interpreter."""
    code = (
        f"import json, sys; import {module}; "
        "print(json.dumps(sorted(m for m in sys.modules "
        "if m.split('.')[0] in ('asictl', 'lark'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return list(json.loads(out.stdout))


def test_the_design_cards_directories():
    assert list((PACKAGE / "grammar").glob("*.lark"))
    assert list((PACKAGE / "codegen8051").glob("*.py"))
    assert not (PACKAGE / "codegen").exists()


def test_the_emulated_board_loads_no_compiler():
    """Like the real firmware, the board runs images: no lark, no IL, no code generator."""
    loaded = modules_after_import("asictl.board.board")
    assert "asictl.board.board" in loaded
    forbidden = [
        m for m in loaded
        if m.split(".")[0] == "lark" or m.startswith(("asictl.il", "asictl.codegen8051"))
        or m in ("asictl.build", "asictl.mcs51.assembler")
    ]
    assert forbidden == []


def test_the_image_format_loads_no_compiler():
    loaded = modules_after_import("asictl.image")
    assert not [m for m in loaded if m.startswith(("lark", "asictl.il", "asictl.codegen8051"))]


def test_checking_loads_no_assembler_image_or_compiler():
    """``asictl check`` reads and checks source: the back end stays unloaded (the
    assembler's reserved words, which the checks need, are a module of their own)."""
    program = "[DECL]\\nx BYTE 1\\n[PROGRAM]\\n    A I 1.0\\n    = Q 1.0\\n    BE\\n"
    code = (
        "import json, sys; from asictl.build import check; "
        "from asictl.source import from_string; "
        f"built = check(from_string('p.asi', '{program}')); "
        "assert built.program is not None and not built.diagnostics, built.render(); "
        "print(json.dumps(sorted(m for m in sys.modules if m.startswith('asictl'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    loaded = json.loads(out.stdout)
    assert {"asictl.il.checks", "asictl.mcs51.words"} <= set(loaded)
    back_end = [
        m for m in loaded
        if m.startswith(("asictl.codegen8051", "asictl.image", "asictl.runtime.contract"))
        or (m.startswith("asictl.mcs51.") and m != "asictl.mcs51.words")
    ]
    assert back_end == []
    assert "asictl.image" not in modules_after_import("asictl.cli.check")


def test_the_command_line_starts_without_its_commands():
    """``asictl --help`` stays fast: commands and their dependencies load when run."""
    loaded = modules_after_import("asictl.cli")
    assert not [m for m in loaded if m.startswith(("lark", "asictl.il", "asictl.board"))]


def test_only_the_monitor_loads_textual():
    """Textual is an optional extra: no other command, nor the monitor's data side, loads it."""
    code = (
        "import sys; import asictl.cli.master, asictl.cli.live, asictl.cli.commission, "
        "asictl.cli.verify, asictl.cli.monitor, asictl.monitor.source, asictl.host.live; "
        "print(any(m.split('.')[0] in ('textual', 'rich') for m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
    loaded = modules_after_import("asictl.monitor.app")
    assert "asictl.monitor.app" in loaded


#: Who looks at a running program stands above what it looks at: the simulation, the
#: debugger and the monitor look through ``observe``; the host and the board know none of
#: them. (Function-local imports count too.)
NOT_IMPORTED_BY = {
    "observe": ("host", "gateway", "sim", "debug", "monitor", "cli", "lsp"),
    "sim": ("debug", "monitor", "cli", "lsp"),
    "host": ("sim", "debug", "monitor", "cli", "lsp"),
    "board": ("host", "observe", "sim", "debug", "monitor", "cli", "lsp", "gateway"),
    "gateway": ("sim", "observe", "debug", "monitor", "cli", "lsp"),
}


def imported_packages(package: str) -> dict[str, set[str]]:
    """The asictl packages each file of ``package`` imports, anywhere in the file."""
    found: dict[str, set[str]] = {}
    for path in (PACKAGE / package).rglob("*.py"):
        names: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module:
                names.add(node.module)
            elif isinstance(node, ast.Import):
                names.update(alias.name for alias in node.names)
        found[path.relative_to(PACKAGE).as_posix()] = {
            name.split(".")[1] for name in names
            if name.startswith("asictl.") and name.count(".") >= 1
        }
    return found


@pytest.mark.parametrize("package", sorted(NOT_IMPORTED_BY))
def test_nothing_imports_upwards(package: str):
    upward = {
        file: sorted(imported & set(NOT_IMPORTED_BY[package]))
        for file, imported in imported_packages(package).items()
        if imported & set(NOT_IMPORTED_BY[package])
    }
    assert upward == {}


def test_the_pytest_plugin_loads_the_simulation_only_to_run_a_scenario():
    """It loads in every pytest run where asictl is installed, scenarios or not."""
    loaded = modules_after_import("asictl.pytest_plugin")
    assert "asictl.sim.session" not in loaded and "lark" not in loaded
