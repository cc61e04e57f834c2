"""The generated assembly, as the listing shows it, assembled by as31: the same bytes.

The compiler assembles its instruction objects without writing them out as text; this
checks the text it lists against an assembler that shares no code with it. The lines are
put into as31's dialect first (``.org``, ``.end``, ``.equ`` for the symbol values the
listing gives as comments, and no ``?`` in names), which changes no instruction. A
variable may be named like an SFR (the manual allows it, and generated code addresses
variables by number): as31 would refuse to redefine it, so its value is not passed on.
The programs are the demos and the generated programs of the golden record (one of them
has a jump relaxed to its long form); those with hand-written assembly are left out, as
theirs is the user's dialect.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from intelhex import IntelHex

from asictl.build import build_file
from asictl.il import ast
from asictl.mcs51.isa import SFR_BITS, SFRS

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
DEMOS = [path.name for path in sorted((ROOT / "demos").glob("*.asi"))]
GENERATED: dict[str, dict[str, str]] = json.loads((HERE / "golden" / "programs.json").read_text())
AS31 = shutil.which("as31")


def as31_dialect(text: str) -> str:
    lines = []
    for line in text.splitlines():
        if value := re.fullmatch(r"; (\S+) = (\S+)", line):
            if value[1].upper() in SFRS or value[1].upper() in SFR_BITS:
                continue
            line = f"\t.equ {value[1]}, {value[2]}"
        line = re.sub(r"^\s+ORG\b", "\t.org", line)
        line = re.sub(r"^\s+END\b", "\t.end", line)
        lines.append(line.replace("?", "_q"))
    return "\n".join(lines) + "\n"


@pytest.mark.skipif(AS31 is None, reason="as31 is not installed")
@pytest.mark.parametrize("name", [*DEMOS, *GENERATED])
def test_as31_assembles_the_listed_code_to_the_same_bytes(name: str, tmp_path: Path):
    assert AS31 is not None
    if name in DEMOS:
        main = ROOT / "demos" / name
    else:
        for file, text in GENERATED[name].items():
            (tmp_path / file).write_text(text)
        main = tmp_path / "main.asi"
    built = build_file(main)
    if built.compiled is None:
        pytest.skip("no code: the program is there for its diagnostics")
    compiled = built.compiled
    if _hand_written(compiled.program.modules()):
        pytest.skip("hand-written assembly")
    source = tmp_path / "generated.asm"
    source.write_text(as31_dialect(compiled.assembly_text))
    result = subprocess.run(
        [AS31, "-Fhex", str(source)], capture_output=True, text=True, check=False
    )
    assert result.returncode == 0 and "rror" not in result.stdout + result.stderr, (
        result.stdout + result.stderr
    )
    image = IntelHex(str(tmp_path / "generated.hex"))
    theirs = {address: image[address] for address in image.addresses()}
    ours = compiled.assembly.byte_map()
    assert theirs == ours
    assert ours, "no code"



def _hand_written(modules: list[ast.Module]) -> bool:
    return any(
        module.sections_of(ast.AssemblySection)
        or any(isinstance(node, ast.Asm) for node in module.code())
        for module in modules
    )
