"""``check`` reports what the image format cannot store, so ``compile`` refuses nothing
that ``check`` passed.

Once, a program with 255 function-block files passed ``check`` and crashed ``compile``
(exit 3), and a variable name over 255 bytes passed ``check`` and failed ``compile``
without a location. The oracle of the property test is the image encoder itself
(``asictl.image.eeprom``): check reports E220/E221/E222 exactly when it would refuse.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from asictl.cli import main
from asictl.il import ast
from asictl.il.checks import check_source
from asictl.il.language import MAX_IMAGE_NAME_BYTES, MAX_SOURCE_FILES
from asictl.il.loader import Program
from asictl.image import eeprom as image
from asictl.source import read_source


def write_program(folder: Path, blocks: int, name_length: int = 4,
                  duplicate: bool = False) -> Path:
    """main.asi calling ``blocks`` block files (the last one, with ``duplicate``, in a
    subfolder under the name of the first), and a variable of ``name_length`` characters."""
    folder.mkdir(parents=True, exist_ok=True)
    files = [f"b{i}.fb" for i in range(blocks)]
    if duplicate and blocks > 1:
        (folder / "sub").mkdir(exist_ok=True)
        files[-1] = "sub/b0.fb"
    variable = "V" + "x" * (name_length - 1)
    decls = "".join(f"B{i} FB {file}\n" for i, file in enumerate(files))
    calls = "".join(f"  JU FB B{i}\n" for i in range(blocks))
    main_file = folder / "main.asi"
    main_file.write_text(f"[DECL]\n{variable} BYTE 1\n{decls}[PROGRAM]\n  L KB 1\n"
                         f"  T {variable} 0\n{calls}  BE\n")
    for file in files:
        (folder / file).write_text("[PROGRAM]\n  BE\n")
    return main_file


def codes(path: Path) -> list[tuple[str, int]]:
    result = check_source(read_source(path))
    return [(d.code, d.span.line if d.span else 0) for d in result.diagnostics]


def test_256_source_files_are_reported_at_the_declaration_of_the_255th_block(tmp_path):
    main_file = write_program(tmp_path, blocks=MAX_SOURCE_FILES)
    assert codes(main_file) == [("E221", 2 + MAX_SOURCE_FILES)]  # [DECL], variable, blocks


def test_255_source_files_check_and_compile(runner: CliRunner, tmp_path: Path):
    main_file = write_program(tmp_path, blocks=MAX_SOURCE_FILES - 1)
    assert codes(main_file) == []
    result = runner.invoke(main, ["compile", str(main_file)])
    assert result.exit_code == 0, result.output


def test_256_source_files_fail_compile_with_a_location_not_a_crash(runner, tmp_path):
    main_file = write_program(tmp_path, blocks=MAX_SOURCE_FILES)
    result = runner.invoke(main, ["compile", str(main_file)])
    assert result.exit_code == 1, result.output
    assert f"{main_file}:{2 + MAX_SOURCE_FILES}:1: error:" in result.stderr
    assert "[E221]" in result.stderr


def test_a_variable_name_over_255_bytes_is_reported_at_its_declaration(runner, tmp_path):
    main_file = write_program(tmp_path, blocks=0, name_length=MAX_IMAGE_NAME_BYTES + 1)
    assert codes(main_file) == [("E220", 2)]
    result = runner.invoke(main, ["compile", str(main_file)])
    assert result.exit_code == 1 and f"{main_file}:2:1: error:" in result.stderr


def test_two_block_files_of_one_name_are_reported(tmp_path):
    main_file = write_program(tmp_path, blocks=3, duplicate=True)
    assert codes(main_file) == [("E222", 5)]


# ----- property: check and the image encoder agree ----------------------------------------


def image_refuses(path: Path) -> bool:
    """Whether the image encoder refuses the program's files or variable names."""
    result = check_source(read_source(path))
    program = result.program
    try:
        files = image.source_files({name: s.raw for name, s in program.sources.items()})
        image.program_identity(files)  # packs every file: count byte and name bytes
        image.pack_sources(files)
        variable = next(d for d in _declarations(program))
        image._name_bytes(variable)
    except (image.ImageError, ValueError):
        return True
    return False


def _declarations(program: Program) -> Iterator[str]:
    for section in program.main.sections_of(ast.DeclSection):
        for decl in section.declarations:
            if isinstance(decl, ast.VarDecl):
                yield decl.name


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(
    blocks=st.sampled_from([0, 1, 2, MAX_SOURCE_FILES - 2, MAX_SOURCE_FILES - 1,
                            MAX_SOURCE_FILES, MAX_SOURCE_FILES + 1]),
    name_length=st.integers(MAX_IMAGE_NAME_BYTES - 3, MAX_IMAGE_NAME_BYTES + 3),
    duplicate=st.booleans(),
)
def test_check_reports_an_image_limit_exactly_when_the_encoder_refuses(
    tmp_path_factory: pytest.TempPathFactory, blocks: int, name_length: int, duplicate: bool
):
    folder = tmp_path_factory.mktemp("program")
    main_file = write_program(folder, blocks, name_length, duplicate)
    reported = {code for code, _ in codes(main_file)}
    assert reported <= {"E220", "E221", "E222"}
    assert bool(reported) == image_refuses(main_file)
