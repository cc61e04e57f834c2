"""From a file to the image a download stores, and from an uploaded image back to files.

A download takes what ACF took, an IL source, and also an image (Intel HEX from
``asictl compile``, or an uploaded file's [RAW] section). Sources are compiled against
the entry points the master itself reports (manual 3.8: "prior to every translation,
the compiler reads the entry point of these functions out of the AS-i master").

An upload gives back the exact source files the image carries (the main file under the
name asked for, its function-block files beside it), or, for an image without source,
a file whose [RAW] section downloads the identical image again.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path, PurePath

from asictl.codegen8051.compiler import GENERATED, compile_program
from asictl.diagnostics import Diagnostic, DiagnosticError
from asictl.errors import ExitCode, UserError
from asictl.files import shown_name, write_together
from asictl.il import ast
from asictl.il.checks import check_source
from asictl.image import ImageError, ProgramImage, build_image, image_from_uploaded, uploaded_source
from asictl.source import read_source


@dataclass
class Prepared:
    """The image to download, or the diagnostics that stop it; texts to show them with."""

    image: ProgramImage | None
    diagnostics: list[Diagnostic] = field(default_factory=list)
    texts: dict[str, str] = field(default_factory=dict)
    #: built from source here (not taken as it was from a .hex file or a [RAW] section)
    compiled: bool = False


def prepare_image(
    path: str, *, entry_points: Mapping[str, int], lib: Iterable[str | Path] = ()
) -> Prepared:
    """The image of ``path`` (.hex: as it is; otherwise IL source, compiled here)."""
    source = read_source(path)
    if Path(path).suffix.lower() == ".hex":
        return Prepared(ProgramImage.from_hex(source.text))
    result = check_source(source, lib=lib)
    program = result.program
    texts = {name: s.text for name, s in program.sources.items()}
    if result.has_errors:
        return Prepared(None, result.diagnostics, texts)
    if program.main.sections_of(ast.RawSection):
        return Prepared(image_from_uploaded(program.main), result.diagnostics, texts)
    try:
        compiled = compile_program(program, entry_points=entry_points)
    except DiagnosticError as exc:
        return Prepared(None, [*result.diagnostics, *exc.diagnostics], texts)
    texts[GENERATED] = compiled.assembly_text
    diagnostics = [*result.diagnostics, *compiled.assembly.diagnostics]
    return Prepared(build_image(compiled), diagnostics, texts, compiled=True)


def uploaded_files(image: ProgramImage, output: str | Path) -> list[tuple[Path, bytes]]:
    """(path, exact bytes) of every file an upload to ``output`` writes, main first.

    The block files' names come from the image, which anyone can craft: each must be a
    plain, printable file name (no folder, no NUL, no escape sequence that would drive
    the terminal it is printed on), or nothing is written.
    """
    output = Path(output)
    sources = image.sources()
    if not sources:
        return [(output, uploaded_source(image).encode("utf-8"))]
    (_, main), *blocks = sources.items()
    files = [(output, main)]
    for name, raw in blocks:
        problem = _name_problem(name)
        if problem:
            raise ImageError(
                f"the image names a source file '{shown_name(name)}', {problem}; "
                "no file was written",
                ExitCode.FAILED,
            )
        files.append((output.parent / name, raw))
    targets = [path.resolve() for path, _ in files]
    if len(set(targets)) != len(targets):
        raise UserError(
            f"{output}: the image has a function-block file of this name; choose another name",
            ExitCode.FAILED,
        )
    return files


def _name_problem(name: str) -> str | None:
    if not name:
        return "with an empty name"
    if not name.isprintable():
        return "with control characters in its name"
    if PurePath(name).name != name or name in (".", ".."):
        return "which is not a plain file name"
    return None


def write_files(files: list[tuple[Path, bytes]], *, overwrite: bool) -> list[Path]:
    """Write the files, all or none; one that exists with other content stops all unless
    ``overwrite``.

    Returns the files written (an existing file with the same bytes is left untouched; a
    device or FIFO is written to as a stream).
    """
    changed = []
    kept = []
    for path, data in files:
        existing = _existing(path)
        if existing == data:
            continue
        changed.append((path, data))
        if existing is not None:
            kept.append(str(path))
    if kept and not overwrite:
        raise UserError(
            f"{', '.join(kept)}: exists with other content; not overwritten "
            "(use --overwrite); no file was written",
            ExitCode.FAILED,
        )
    write_together(changed)
    return [path for path, _ in changed]


def _existing(path: Path) -> bytes | None:
    """The bytes of a regular file at ``path``; None if there is none (reading a FIFO
    would wait for a writer, and a device is not replaced but written to)."""
    try:
        if not path.is_file():
            return None
        return path.read_bytes()
    except OSError as exc:
        raise UserError(f"{path}: cannot read: {exc.strerror or exc}") from None
