"""Draw the layer table of docs/architecture.md from ``asictl.LAYERS``.

The table between the two markers in docs/architecture.md is generated: one row per
package or top-level module, highest layer first, with what it holds and its modules.
Run it after changing ``asictl.LAYERS`` or adding a module:

    python3 tools/architecture.py          # rewrite the table
    python3 tools/architecture.py --check  # exit 1 if the document is out of date
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from drawn import redraw  # noqa: E402 - beside this file

from asictl import LAYERS  # noqa: E402 - after the path is set

DOC = ROOT / "docs" / "architecture.md"
PACKAGE = ROOT / "src" / "asictl"
BEGIN = "<!-- layers: drawn from asictl.LAYERS by tools/architecture.py -->"
END = "<!-- end of layers -->"


def _modules(name: str) -> str:
    folder = PACKAGE / name
    if not folder.is_dir():
        return ""
    files = sorted(
        p.relative_to(folder).as_posix() for p in folder.rglob("*")
        if p.suffix in (".py", ".lark") and p.name != "__init__.py"
        and "__pycache__" not in p.parts
    )
    return ", ".join(f"`{f.removesuffix('.py')}`" for f in files) or "-"


def table() -> str:
    rows = [
        "",
        "| layer | package or module | what it holds | its modules |",
        "|---|---|---|---|",
    ]
    for level in range(len(LAYERS) - 1, -1, -1):
        for name, about in LAYERS[level]:
            shown = f"`{name}/`" if (PACKAGE / name).is_dir() else f"`{name}.py`"
            rows.append(f"| {level} | {shown} | {about} | {_modules(name)} |")
    return "\n".join(rows) + "\n\n"


def main(argv: list[str]) -> int:
    return redraw(DOC, BEGIN, END, table(), argv, "python3 tools/architecture.py")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
