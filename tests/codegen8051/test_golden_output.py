"""The compiler's output, byte for byte, against images it made before.

Every demo, every program of the tests' scenarios and docs, every example of the manual
and a fixed set of generated programs are built through the build API, and each image is
compared with the one recorded in ``golden/images.json``. A change to the front end or
the code generator that is meant to leave the code alone (a new AST, instructions
emitted as objects) must pass this unchanged; a change that is meant to improve the code
rewrites the record, and the diff of that file shows which programs it touched.

The generated programs are stored as source text in ``golden/programs.json`` (drawn once
from ``il_strategies``): the set stays the same whatever becomes of the strategies or of
hypothesis. What is compared is the whole image less its identity, which hashes the
compiler's version number in (a new version is no change of the code); the code bytes
are recorded as well, so a failure says whether the code itself changed.

To record the images anew (after a change that is meant to change them)::

    python3 tests/codegen8051/test_golden_output.py --images

and to draw a new set of generated programs (which also records their images)::

    python3 tests/codegen8051/test_golden_output.py --programs
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from asictl.build import build_file

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
GOLDEN = HERE / "golden"
IMAGES = GOLDEN / "images.json"
PROGRAMS = GOLDEN / "programs.json"
#: Program files kept in the tree, compiled where they lie (their blocks beside them).
SOURCE_DIRS = ("demos", "tests/scenarios", "docs/debugging")
GENERATED = 160


def _tree_programs() -> dict[str, Path]:
    return {
        path.relative_to(ROOT).as_posix(): path
        for folder in SOURCE_DIRS
        for path in sorted((ROOT / folder).glob("*.asi"))
    }


def _text_programs() -> dict[str, dict[str, str]]:
    """The manual's examples and the generated programs: name -> file name -> text."""
    sys.path.insert(0, str(HERE.parent))
    from manual_examples import EXAMPLES

    programs = {f"manual/{name}": {"main.asi": text} for name, text in EXAMPLES.items()}
    if PROGRAMS.exists():  # (while a new set is drawn, it does not)
        programs.update(json.loads(PROGRAMS.read_text()))
    return programs


def _record(built_image: object) -> dict[str, str]:
    from asictl.image.eeprom import ProgramImage

    assert isinstance(built_image, ProgramImage)
    image = replace(built_image, identity=bytes(len(built_image.identity)))
    return {
        "code": built_image.code.hex(),
        "image": hashlib.sha256(image.to_bytes()).hexdigest(),
    }


def _build(main: Path) -> dict[str, str] | None:
    """The record of a program's image, or None where it has no image (a fragment that
    does not compile, an error the program is there to show)."""
    built = build_file(main)
    return None if built.image is None else _record(built.image)


def _build_text(files: dict[str, str], folder: Path) -> dict[str, str] | None:
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (folder / name).write_text(text, encoding="utf-8")
    return _build(folder / "main.asi")


def _all_records(scratch: Path) -> dict[str, dict[str, str] | None]:
    records: dict[str, dict[str, str] | None] = {
        name: _build(path) for name, path in _tree_programs().items()
    }
    for n, (name, files) in enumerate(_text_programs().items()):
        records[name] = _build_text(files, scratch / str(n))
    return records


def _golden() -> dict[str, dict[str, str] | None]:
    return json.loads(IMAGES.read_text())


def _names() -> list[str]:
    return [*_tree_programs(), *_text_programs()]


def test_the_record_covers_every_program_and_many_images():
    golden = _golden()
    assert set(golden) == {*_tree_programs(), *_text_programs()}
    compiled = [name for name, record in golden.items() if record is not None]
    assert len([n for n in compiled if n.startswith("generated/")]) >= GENERATED * 9 // 10
    assert all(golden[f"demos/{p.name}"] for p in (ROOT / "demos").glob("*.asi"))


@pytest.mark.parametrize("name", _names())
def test_image_is_byte_identical(name: str, tmp_path: Path) -> None:
    golden = _golden()
    assert name in golden, f"{name}: no image recorded (record them with --images)"
    expected = golden[name]
    trees = _tree_programs()
    got = _build(trees[name]) if name in trees else _build_text(_text_programs()[name], tmp_path)
    if expected is None or got is None:
        assert got == expected, f"{name}: built an image {'now' if got else 'before'} only"
        return
    if got["code"] != expected["code"]:
        old, new = bytes.fromhex(expected["code"]), bytes.fromhex(got["code"])
        pairs = enumerate(zip(old, new, strict=False))
        at = next((i for i, (a, b) in pairs if a != b), min(len(old), len(new)))
        pytest.fail(f"{name}: the code differs from byte {at} on ({len(old)} bytes before, "
                    f"{len(new)} now)")
    assert got["image"] == expected["image"], f"{name}: same code, but the image differs"


# ------------------------------------------------------------------ recording


def _draw_programs(count: int) -> dict[str, dict[str, str]]:
    """``count`` checked programs drawn from the tests' strategies, as source files: each
    the last of a few examples of its own seed (deterministic for one version of
    hypothesis and of the strategies; the first examples of a run are the plainest)."""
    from hypothesis import HealthCheck, Phase, given, seed, settings
    from il_strategies import checked_programs

    drawn: dict[str, dict[str, str]] = {}

    def last_of(n: int) -> dict[str, str]:
        last: list[dict[str, str]] = []

        @seed(n)
        @settings(max_examples=8, database=None, deadline=None, phases=[Phase.generate],
                  suppress_health_check=list(HealthCheck))
        @given(checked_programs(asm=n % 2 == 1, options=True))
        def collect(program) -> None:  # type: ignore[no-untyped-def]
            files = {"main.asi": program.main.to_source()}
            files.update({m.file: m.to_source() for m in program.blocks.values()})
            last[:] = [files]

        collect()
        return last[0]

    for n in range(count):
        drawn[f"generated/{n:03}"] = last_of(n)
    return drawn


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--images", action="store_true", help="record the images anew")
    parser.add_argument("--programs", action="store_true",
                        help="draw a new set of generated programs, and record all images")
    args = parser.parse_args()
    if not (args.images or args.programs):
        parser.error("say --images or --programs")
    sys.path.insert(0, str(HERE.parent))
    GOLDEN.mkdir(exist_ok=True)
    if args.programs:
        PROGRAMS.write_text(json.dumps(_draw_programs(GENERATED), indent=1) + "\n")
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        records = _all_records(Path(scratch))
    IMAGES.write_text(json.dumps(records, indent=1) + "\n")
    built = sum(1 for r in records.values() if r is not None)
    print(f"{IMAGES.relative_to(ROOT)}: {built} images of {len(records)} programs")


if __name__ == "__main__":
    main()
