"""``asictl compile``: IL source to the program image a master stores (docs/compile.md).

This is the manual's ACF tokenizer without the download (``/d-``): it checks the program,
compiles it and writes the image as Intel HEX, with the listing (CTRL.{a}) on request and
the step log (CTRL2.{l}) with -v.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import click

from asictl.codegen8051.compiler import GENERATED, Compiled, compile_program
from asictl.diagnostics import DiagnosticError, Severity, render_text
from asictl.errors import ExitCode, UserError
from asictl.files import write_output
from asictl.il import ast
from asictl.il.checks import check_source
from asictl.il.loader import Program
from asictl.image import (
    MAGIC,
    build_image,
    image_from_uploaded,
    pack_sources,
    source_files,
)
from asictl.listing import (
    LISTING_MARK,
    cells_summary,
    code_summary,
    data_summary,
    image_size_summary,
    listing_text,
    raw_listing_text,
)
from asictl.source import read_source

_OUTPUT = click.Path(dir_okay=False)
#: The first record of every image asictl writes: 16 bytes at address 0, starting with MAGIC.
_IMAGE_FIRST_RECORD = ":10000000" + MAGIC.hex().upper()


class _Log:
    """The verbose step log: one line per step on stderr, with the step's time."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.started = time.perf_counter()

    def __call__(self, message: str) -> None:
        if self.enabled:
            click.echo(message, err=True)

    def step(self, message: str) -> None:
        """Log a step that ended now, with the time since the previous step."""
        now = time.perf_counter()
        self(f"{message} ({(now - self.started) * 1000:.0f} ms)")
        self.started = now


def _is_image_hex(first_line: str) -> bool:
    return first_line.strip().upper().startswith(_IMAGE_FIRST_RECORD)


def _is_listing(first_line: str) -> bool:
    return first_line.startswith(LISTING_MARK)


def _check_target(
    path: str, recognise: Callable[[str], bool], what: str, program: Program, force: bool
) -> None:
    """The overwrite policy: replace asictl's own outputs, anything else only with --force.

    A source file of the program is never replaced, not even with --force.
    """
    target = Path(path)
    inputs = {Path(name).resolve() for name in program.sources if name != "<stdin>"}
    if target.resolve() in inputs:
        raise UserError(f"{path}: is a source file of this program; not overwritten")
    if force or not target.is_file():
        return  # nothing there, or a device or FIFO, which is written to as a stream
    try:
        with target.open("rb") as existing:
            first_line = existing.readline(200).decode("latin-1")
    except OSError as exc:
        raise UserError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if not recognise(first_line):
        raise UserError(
            f"{path}: exists and is not an asictl {what}; not overwritten (use --force)"
        )


def _summary_counts(diagnostics) -> tuple[int, int]:
    errors = sum(d.severity is Severity.ERROR for d in diagnostics)
    return errors, len(diagnostics) - errors


@click.command("compile")
@click.argument("source", metavar="FILE.asi")
@click.option(
    "-o", "--output", type=_OUTPUT,
    help="The image as Intel HEX [default: FILE.hex next to the source]; - for stdout.",
)
@click.option(
    "--listing", type=_OUTPUT,
    help="Also write a listing: each IL line with its assembly, then the memory map.",
)
@click.option("-v", "--verbose", is_flag=True, help="Log every step on stderr.")
@click.option(
    "--lib", "lib", multiple=True, type=click.Path(file_okay=False),
    help="Also look for function-block files here (repeatable; also $ASICTL_LIB).",
)
@click.option("--no-source", is_flag=True, help="Leave the source text out of the image.")
@click.option(
    "--force", is_flag=True, help="Overwrite output files that are not asictl images or listings.",
)
def compile_(
    source: str, output: str | None, listing: str | None, verbose: bool,
    lib: tuple[str, ...], no_source: bool, force: bool,
) -> None:
    """Compile the IL program FILE.asi (- for stdin) into an image for the master.

    Checks the program as 'asictl check' does (warnings are shown, errors stop here),
    compiles it to 8051 code, and writes the image the master's EEPROM holds: code,
    program map, [OPTIONS] flags, [SETUP] configuration and, when it fits, the source
    text. A file with a [RAW] section (from an upload) gives back its image unchanged.

    Output files are replaced in one step, never left half-written. An existing file is
    only replaced if it is an asictl image (or listing); anything else needs --force.

    Exit status: 0 compiled, 1 errors in the program or it does not fit, 2 bad usage or
    an unreadable file.
    """
    if source == "-" and output is None:
        raise click.UsageError("reading standard input needs -o FILE.hex")
    hex_path = output or str(Path(source).with_suffix(".hex"))
    if listing and hex_path != "-" and Path(listing).resolve() == Path(hex_path).resolve():
        raise click.UsageError("the listing and the image cannot be the same file")
    ctx = click.get_current_context()
    log = _Log(verbose)

    main_source = read_source(source)
    result = check_source(main_source, lib=lib)
    program = result.program
    for name, text in program.sources.items():
        log(f"read {name} ({len(text.raw)} bytes)")
    texts = {name: s.text for name, s in program.sources.items()}
    click.echo(render_text(result.diagnostics, texts), nl=False, err=True)
    errors, warnings = _summary_counts(result.diagnostics)
    log.step(f"checked: {errors} errors, {warnings} warnings")
    if errors:
        ctx.exit(int(ExitCode.FAILED))

    if hex_path != "-":
        _check_target(hex_path, _is_image_hex, "image", program, force)
    if listing:
        _check_target(listing, _is_listing, "listing", program, force)

    compiled: Compiled | None = None
    if program.main.sections_of(ast.RawSection):
        image = image_from_uploaded(program.main)
        log.step("image read from the [RAW] section")
    else:
        try:
            compiled = compile_program(program)
        except DiagnosticError as exc:
            click.echo(render_text(exc.diagnostics, texts), nl=False, err=True)
            ctx.exit(int(ExitCode.FAILED))
        texts[GENERATED] = compiled.assembly_text
        click.echo(render_text(compiled.diagnostics, texts), nl=False, err=True)
        log(f"allocated {cells_summary(compiled.pmap)}; {data_summary(compiled.pmap)}")
        log.step(f"assembled {len(compiled.lines)} lines of 8051 assembly")
        image = build_image(compiled, with_source=not no_source)
        log.step("image built")
    log(f"code: {code_summary(image)}")
    log(f"image: {image_size_summary(image)}")
    log(f"identity: {image.identity_hex}")
    if image.source_left_out:
        files = source_files({name: s.raw for name, s in program.sources.items()})
        click.echo(
            f"asictl: warning: the source text ({len(pack_sources(files))} bytes compressed) "
            "does not fit in the image and is left out; an upload will give [RAW] records "
            "instead of the program text",
            err=True,
        )

    inputs = list(program.sources)
    if hex_path == "-":
        click.echo(image.to_hex(), nl=False)
    else:
        write_output(hex_path, image.to_hex(), inputs=inputs)
        log(f"wrote {hex_path}")
    if listing:
        name = next(iter(program.sources))
        write_output(
            listing,
            listing_text(compiled, image) if compiled else raw_listing_text(name, image),
            inputs=inputs,
        )
        log(f"wrote {listing}")
    click.echo(
        f"{hex_path if hex_path != '-' else '<stdout>'}: {len(image.code)} bytes of code, "
        f"image {len(image.to_bytes())} bytes, identity {image.identity_hex}",
        err=True,
    )
