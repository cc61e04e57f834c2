"""The layout the pipeline asks for: each step in one place, nothing importing upwards."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

from asictl import LAYERS

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
    loaded = modules_after_import("asictl.image.eeprom")
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
        if m.startswith(("asictl.codegen8051", "asictl.image.eeprom", "asictl.runtime.contract"))
        or (m.startswith("asictl.mcs51.") and m != "asictl.mcs51.words")
    ]
    assert back_end == []
    assert "asictl.image.eeprom" not in modules_after_import("asictl.cli.check")


def test_the_command_line_starts_without_its_commands():
    """``asictl --help`` stays fast: commands and their dependencies load when run."""
    loaded = modules_after_import("asictl.cli")
    assert not [m for m in loaded if m.startswith(("lark", "asictl.il", "asictl.board"))]


def test_only_the_monitor_loads_textual():
    """Textual is an optional extra: no other command, nor the monitor's data side, loads it."""
    code = (
        "import sys; import asictl.cli.master, asictl.cli.live, asictl.cli.commission, "
        "asictl.cli.verify, asictl.cli.monitor, asictl.monitor.source, "
        "asictl.host.live.server, asictl.host.live.client; "
        "print(any(m.split('.')[0] in ('textual', 'rich') for m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
    loaded = modules_after_import("asictl.monitor.app")
    assert "asictl.monitor.app" in loaded


def _rank() -> dict[str, int]:
    return {name: level for level, layer in enumerate(LAYERS) for name, _ in layer}


def _unit(path: Path) -> str:
    """The package (folder) or top-level module a file of ``src/asictl`` belongs to."""
    first = path.relative_to(PACKAGE).parts[0]
    return first.removesuffix(".py")


def imported_units(path: Path) -> set[str]:
    """The asictl packages and top-level modules ``path`` imports, anywhere in the file
    (function-local imports count too); the package face itself is not counted."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            if node.module == "asictl":
                found.update(a.name for a in node.names if a.name not in ("__version__", "LAYERS"))
            elif node.module.startswith("asictl."):
                found.add(node.module.split(".")[1])
        elif isinstance(node, ast.Import):
            found.update(a.name.split(".")[1] for a in node.names if a.name.startswith("asictl."))
    return found


def private_imports(path: Path) -> list[str]:
    """The names beginning with ``_`` that ``path`` imports from another asictl module
    (``from asictl.x import _name``, or ``x._name`` of an asictl module it imported);
    dunders such as ``__version__`` are public."""
    found: list[str] = []
    modules: set[str] = set()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "asictl":
            for alias in node.names:
                modules.add(alias.asname or alias.name)
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    found.append(f"{node.module}.{alias.name}")
        elif isinstance(node, ast.Import):
            modules.update(
                alias.asname or alias.name.split(".")[0] for alias in node.names
                if alias.name.split(".")[0] == "asictl"
            )
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
            and node.value.id in modules
            and node.attr.startswith("_") and not node.attr.startswith("__")
        ):
            found.append(f"{node.value.id}.{node.attr}")
    return found


def test_no_module_imports_another_modules_private_names():
    """A name another module needs is public, in the module that owns it (the board
    options of every command that reaches a master are ``cli/board_options.py``)."""
    taken = {
        path.relative_to(PACKAGE).as_posix(): found
        for path in sorted(PACKAGE.rglob("*.py"))
        if (found := private_imports(path))
    }
    assert taken == {}


def test_the_private_import_check_sees_both_ways(tmp_path: Path):
    """The rule above would pass vacuously if it read no imports: it must see these."""
    sample = tmp_path / "x.py"
    sample.write_text(
        "from asictl import __version__\n"
        "from asictl.cli.master import _connect, open_master\n"
        "from asictl.host import boards\n"
        "boards._load(boards.state_file)\n",
        encoding="utf-8",
    )
    assert private_imports(sample) == ["asictl.cli.master._connect", "boards._load"]


def test_every_package_and_module_has_a_layer():
    """A new package or top-level module must be placed in ``asictl.LAYERS`` (once)."""
    names = [name for layer in LAYERS for name, _ in layer]
    assert len(names) == len(set(names))
    on_disk = {
        p.name.removesuffix(".py") for p in PACKAGE.iterdir()
        if (p.is_dir() and p.name != "__pycache__") or (p.suffix == ".py" and p.stem != "__init__")
    }
    assert on_disk == set(names)


def test_the_top_level_holds_only_the_face_and_what_every_layer_uses():
    loose = sorted(
        p.name for p in PACKAGE.glob("*.py") if p.name not in ("__init__.py", "__main__.py")
    )
    assert len(loose) <= 8, loose
    assert not (PACKAGE / "il" / "reference.py").exists()


def test_nothing_imports_upwards_or_sideways():
    """Every file imports only from lower layers (or its own package)."""
    rank = _rank()
    wrong = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        unit = _unit(path)
        bad = sorted(
            other for other in imported_units(path)
            if other != unit and rank[other] >= rank[unit]
        )
        if bad:
            wrong[path.relative_to(PACKAGE).as_posix()] = bad
    assert wrong == {}


def test_the_layer_check_sees_an_upward_import(tmp_path: Path):
    """The rule above would pass vacuously if it read no imports: it must see this one."""
    sample = tmp_path / "x.py"
    sample.write_text("def f():\n    from asictl.cli.check import check\n", encoding="utf-8")
    assert imported_units(sample) == {"cli"}


def test_the_architecture_doc_is_drawn_from_the_layer_table():
    out = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "architecture.py"), "--check"],
        capture_output=True, text=True,
    )
    assert out.returncode == 0, out.stdout + out.stderr


def test_the_pytest_plugin_loads_the_simulation_only_to_run_a_scenario():
    """It loads in every pytest run where asictl is installed, scenarios or not."""
    loaded = modules_after_import("asictl.pytest_plugin")
    assert "asictl.sim.session" not in loaded and "lark" not in loaded
