"""``asictl compile`` as a user sees it: the image it writes, the listing, the log, errors."""

from __future__ import annotations

import random
import re
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from asictl.build import build_image
from asictl.cli import main
from asictl.codegen8051.compiler import Compiled, compile_program
from asictl.host.program_files import uploaded_source
from asictl.il.checks import check_source
from asictl.image.eeprom import ProgramImage
from asictl.source import read_source

DEMO = Path(__file__).resolve().parent.parent / "demos" / "blink.asi"


@pytest.fixture
def blink(tmp_path: Path) -> Path:
    path = tmp_path / "blink.asi"
    shutil.copy(DEMO, path)
    return path


def compiled(path: Path) -> Compiled:
    return compile_program(check_source(read_source(path)).program)


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_writes_the_image_next_to_the_source(runner: CliRunner, blink: Path):
    result = runner.invoke(main, ["compile", str(blink)])
    assert result.exit_code == 0, result.output
    image = ProgramImage.from_hex(blink.with_suffix(".hex").read_text())
    expected = compiled(blink)
    assert image.code == expected.code
    assert image.pmap == expected.pmap
    assert image.sources() == {"blink.asi": blink.read_bytes()}
    assert result.stderr.splitlines()[-1] == (
        f"{blink.with_suffix('.hex')}: {len(expected.code)} bytes of code, "
        f"image {len(image.to_bytes())} bytes, identity {image.identity_hex}"
    )
    assert result.stdout == ""


def test_output_option_and_stdout(runner: CliRunner, blink: Path, tmp_path: Path):
    out = tmp_path / "other.hex"
    assert runner.invoke(main, ["compile", str(blink), "-o", str(out)]).exit_code == 0
    result = runner.invoke(main, ["compile", str(blink), "-o", "-"])
    assert result.exit_code == 0
    assert result.stdout == out.read_text()
    assert not blink.with_suffix(".hex").exists()


def test_stdin_needs_an_output_file(runner: CliRunner, blink: Path):
    result = runner.invoke(main, ["compile", "-"], input=blink.read_text())
    assert result.exit_code == 2
    assert "reading standard input needs -o" in result.stderr


def test_listing_lists_each_il_line_then_its_assembly(runner: CliRunner, blink: Path):
    listing = blink.with_suffix(".lst")
    result = runner.invoke(main, ["compile", str(blink), "--listing", str(listing)])
    assert result.exit_code == 0, result.output
    rows = listing.read_text().splitlines()
    assert rows[0] == f"; asictl compile listing of {blink}"
    program = compiled(blink)
    source = blink.read_text().splitlines()
    position = 0
    for entry in program.assembly.listing:
        span = program.lines[entry.span.line - 1].span
        if span is None or not entry.data:
            continue
        il_row = next(
            i for i, row in enumerate(rows)
            if row.startswith(f"{span.line:>7} ") and row.endswith(source[span.line - 1].rstrip())
        )
        asm_row = next(
            i for i, row in enumerate(rows)
            if row.strip().startswith(f"{entry.address:04X}  {entry.data[:4].hex(' ').upper()}")
        )
        assert il_row < asm_row  # the IL line comes first, then what it became
        assert position <= asm_row
        position = asm_row
    listed = [int(m[1]) for row in rows if (m := re.match(r" {0,6}(\d+)(?: |$)", row))]
    assert listed == list(range(1, len(source) + 1))  # every source line, once, in order
    text = listing.read_text()
    assert f"; code      {len(program.code)} bytes at 4000h-" in text
    assert "; memory    2 cells: 2 in bit memory, 0 direct, 0 in XDATA" in text
    assert "; T 0 " in text


def test_listing_switches_files_for_function_blocks(runner: CliRunner, tmp_path: Path):
    write(tmp_path, "mean.fb", "[PROGRAM]\n    L FY 1\n    T FY 2\n")
    main_file = write(tmp_path, "main.asi", "[DECL]\nMEAN FB mean.fb\n[PROGRAM]\n    JU FB MEAN\n")
    listing = tmp_path / "main.lst"
    result = runner.invoke(main, ["compile", str(main_file), "--listing", str(listing)])
    assert result.exit_code == 0, result.output
    text = listing.read_text()
    assert text.index(f"; ---- {main_file}") < text.index(f"; ---- {tmp_path / 'mean.fb'}")


def test_verbose_log(runner: CliRunner, blink: Path):
    listing = blink.with_suffix(".lst")
    result = runner.invoke(main, ["compile", "-v", str(blink), "--listing", str(listing)])
    assert result.exit_code == 0
    log = result.stderr
    for expected in (
        f"read {blink} ({blink.stat().st_size} bytes)",
        "checked: 0 errors, 0 warnings (",
        "allocated 2 cells: 2 in bit memory",
        "lines of 8051 assembly (",
        "code: ",
        "image: ",
        "identity: ",
        f"wrote {blink.with_suffix('.hex')}",
        f"wrote {listing}",
    ):
        assert expected in log, expected


@pytest.mark.parametrize(
    ("text", "messages"),
    [
        pytest.param(  # found by the checks
            "[PROGRAM]\n    A I 1.0\n    = Q 32.0\n",
            [":3:7: error: slave address 32 out of range 0..31 [E201]"],
            id="check",
        ),
        pytest.param(  # found by the compiler, reported at the IL line
            "[PROGRAM]\n    BE\n[ASSEMBLY]\n    MOV A,@R5\n",
            [":4:5: error: invalid indirect operand '@R5'", "\n      MOV A,@R5\n      ^~~~~~~~~\n"],
            id="compile",
        ),
        pytest.param(
            "[PROGRAM]\n    BE\n[ASSEMBLY]\n    DS 16300\n",
            ["error: image needs ", "bytes, the EEPROM holds 16384"],
            id="too-big",
        ),
    ],
)
def test_errors_exit_1_and_write_nothing(
    runner: CliRunner, tmp_path: Path, text: str, messages: list[str]
):
    path = write(tmp_path, "bad.asi", text)
    result = runner.invoke(main, ["compile", str(path), "--listing", str(tmp_path / "bad.lst")])
    assert result.exit_code == 1
    for message in messages:
        assert message in result.stderr
    assert list(tmp_path.iterdir()) == [path]


def test_warnings_are_shown_and_compile_goes_on(runner: CliRunner, tmp_path: Path):
    path = write(tmp_path, "w.asi", "[PROGRAM]\n    L KT 505\n    A I 1.0\n    S T 0\n")
    result = runner.invoke(main, ["compile", str(path)])
    assert result.exit_code == 0
    assert "warning: timers count in 10 ms steps" in result.stderr
    assert path.with_suffix(".hex").exists()


def test_unreadable_source_exits_2(runner: CliRunner, tmp_path: Path):
    result = runner.invoke(main, ["compile", str(tmp_path / "missing.asi")])
    assert result.exit_code == 2
    assert "cannot read" in result.stderr


# ----------------------------------------------------------------------- overwrite policy


def test_own_outputs_are_replaced(runner: CliRunner, blink: Path):
    listing = blink.with_suffix(".lst")
    args = ["compile", str(blink), "--listing", str(listing)]
    assert runner.invoke(main, args).exit_code == 0
    blink.write_text(blink.read_text().replace("KT 500", "KT 700"))
    assert runner.invoke(main, args).exit_code == 0
    assert "MOV R2,#046h" in listing.read_text()  # 700 ms = 70 ticks
    assert ProgramImage.from_hex(blink.with_suffix(".hex").read_text()).code == (
        compiled(blink).code
    )


@pytest.mark.parametrize("target", ["hex", "lst"])
def test_foreign_files_are_kept_without_force(runner: CliRunner, blink: Path, target: str):
    other = blink.with_suffix(f".{target}")
    other.write_text("precious\n")
    args = ["compile", str(blink), "--listing", str(blink.with_suffix(".lst"))]
    result = runner.invoke(main, args)
    assert result.exit_code == 2
    assert f"{other}: exists and is not an asictl" in result.stderr
    assert "(use --force)" in result.stderr
    assert other.read_text() == "precious\n"
    assert runner.invoke(main, [*args, "--force"]).exit_code == 0
    assert other.read_text() != "precious\n"


def test_a_source_file_is_never_an_output(runner: CliRunner, blink: Path):
    before = blink.read_bytes()
    for extra in ([], ["--force"]):
        result = runner.invoke(main, ["compile", str(blink), "-o", str(blink), *extra])
        assert result.exit_code == 2
        assert "is a source file of this program" in result.stderr
    assert blink.read_bytes() == before


def test_listing_and_image_must_differ(runner: CliRunner, blink: Path):
    out = str(blink.with_suffix(".hex"))
    result = runner.invoke(main, ["compile", str(blink), "-o", out, "--listing", out])
    assert result.exit_code == 2


# ----------------------------------------------------------------------- source and [RAW]


def test_no_source_option(runner: CliRunner, blink: Path):
    assert runner.invoke(main, ["compile", str(blink), "--no-source"]).exit_code == 0
    image = ProgramImage.from_hex(blink.with_suffix(".hex").read_text())
    assert image.sources() == {} and not image.source_left_out


def test_source_too_big_is_left_out_with_a_warning(runner: CliRunner, tmp_path: Path):
    rng = random.Random(3)
    comments = "".join(f"; {rng.getrandbits(256):064x}\n" for _ in range(900))
    path = write(tmp_path, "long.asi", comments + "[PROGRAM]\n    A I 1.0\n    = Q 1.0\n")
    result = runner.invoke(main, ["compile", str(path)])
    assert result.exit_code == 0
    assert "warning: the source text (" in result.stderr
    assert "does not fit in the image and is left out" in result.stderr
    assert ProgramImage.from_hex(path.with_suffix(".hex").read_text()).source_left_out


def test_uploaded_raw_file_compiles_to_the_identical_image(runner: CliRunner, blink: Path):
    image = build_image(compiled(blink), with_source=False)
    uploaded = blink.with_name("uploaded.asi")
    uploaded.write_text(uploaded_source(image))
    listing = blink.with_name("uploaded.lst")
    result = runner.invoke(main, ["compile", str(uploaded), "--listing", str(listing)])
    assert result.exit_code == 0, result.output
    assert uploaded.with_suffix(".hex").read_text() == image.to_hex()
    assert "there is no IL source to list" in listing.read_text()


def test_edited_uploaded_file_exits_1(runner: CliRunner, blink: Path):
    image = build_image(compiled(blink), with_source=False)
    uploaded = blink.with_name("uploaded.asi")
    uploaded.write_text(uploaded_source(image).replace("auto_start: yes", "auto_start: no"))
    result = runner.invoke(main, ["compile", str(uploaded)])
    assert result.exit_code == 1
    assert "do not match the [RAW] image" in result.stderr
    assert not uploaded.with_suffix(".hex").exists()
