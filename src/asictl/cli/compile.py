"""``asictl compile``: IL source to the program image a master stores (docs/compile.md).

This is the manual's ACF tokenizer without the download (``/d-``): it checks the program,
compiles it and writes the image as Intel HEX, with the listing (CTRL.{a}) on request and
the step log (CTRL2.{l}) with -v.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import click

from asictl.build import Build, Origin, Stage, build_file
from asictl.cli.options import lib_option
from asictl.cli.terminal import stderr_colour
from asictl.codegen8051.listing import (
    LISTING_MARK,
    cells_summary,
    code_summary,
    data_summary,
    image_size_summary,
    listing_text,
    raw_listing_text,
)
from asictl.diagnostics import Diagnostic, Severity
from asictl.errors import ExitCode, UserError
from asictl.files import real_path, write_output
from asictl.image.eeprom import MAGIC, pack_sources, source_files

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
    path: str, recognise: Callable[[str], bool], what: str, sources: Mapping[str, object],
    force: bool,
) -> None:
    """The overwrite policy: replace asictl's own outputs, anything else only with --force.

    A source file of the program is never replaced, not even with --force.
    """
    target = Path(path)
    inputs = {real_path(name) for name in sources if name != "<stdin>"}
    if real_path(target) in inputs:
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


def _summary_counts(diagnostics: Sequence[Diagnostic]) -> tuple[int, int]:
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
@lib_option
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

    \b
    Example:
      asictl compile demos/blink.asi -o blink.hex --listing blink.lst
    """
    if source == "-" and output is None:
        raise click.UsageError("reading standard input needs -o FILE.hex")
    hex_path = output or str(Path(source).with_suffix(".hex"))
    if listing and hex_path != "-" and real_path(listing) == real_path(hex_path):
        raise click.UsageError("the listing and the image cannot be the same file")
    ctx = click.get_current_context()
    log = _Log(verbose)

    def on_stage(stage: Stage, built: Build) -> None:
        if stage is Stage.CHECKED:
            for name, text in built.program.sources.items() if built.program else ():
                log(f"read {name} ({len(text.raw)} bytes)")
            errors, warnings = _summary_counts(built.diagnostics)
            log.step(f"checked: {errors} errors, {warnings} warnings")
        elif stage is Stage.COMPILED and built.compiled is not None:
            pmap = built.compiled.pmap
            log(f"allocated {cells_summary(pmap)}; {data_summary(pmap)}")
            log.step(f"assembled {len(built.compiled.lines)} lines of 8051 assembly")
        elif stage is Stage.IMAGE:
            log.step("image built")

    built = build_file(source, lib=lib, with_source=not no_source, on_stage=on_stage)
    click.echo(built.render(colour=stderr_colour()), nl=False, err=True)
    image = built.image
    if built.has_errors or image is None:
        ctx.exit(int(ExitCode.FAILED))
    if built.origin is not Origin.SOURCE:
        log.step(f"image read from {'the [RAW] section' if built.origin is Origin.RAW else source}")
    sources = built.program.sources if built.program else {}
    if hex_path != "-":
        _check_target(hex_path, _is_image_hex, "image", sources, force)
    if listing:
        _check_target(listing, _is_listing, "listing", sources, force)
    log(f"code: {code_summary(image)}")
    log(f"image: {image_size_summary(image)}")
    log(f"identity: {image.identity_hex}")
    if image.source_left_out and built.compiled is not None:
        files = source_files({name: s.raw for name, s in sources.items()})
        click.echo(
            f"asictl: warning: the source text ({len(pack_sources(files))} bytes compressed) "
            "does not fit in the image and is left out; an upload will give [RAW] records "
            "instead of the program text",
            err=True,
        )

    inputs = [source, *sources]
    write_output(hex_path, image.to_hex(), inputs=inputs)
    if hex_path != "-":
        log(f"wrote {hex_path}")
    if listing:
        write_output(
            listing,
            listing_text(built.compiled, image) if built.compiled
            else raw_listing_text(built.name, image),
            inputs=inputs,
        )
        log(f"wrote {listing}")
    click.echo(
        f"{hex_path if hex_path != '-' else '<stdout>'}: {len(image.code)} bytes of code, "
        f"image {len(image.to_bytes())} bytes, identity {image.identity_hex}",
        err=True,
    )
