"""From an uploaded image back to files (the way there is ``asictl.build``).

An upload gives back the exact source files the image carries (the main file under the
name asked for, its function-block files beside it, its symbol table as
``NAME.symbols.toml`` for the name asked for), or, for an image without source, a file
whose [RAW] section downloads the identical image again.
"""

from __future__ import annotations

from pathlib import Path, PurePath

from asictl.errors import ExitCode, UserError
from asictl.files import real_path, shown_name, write_together
from asictl.il import ast
from asictl.image.eeprom import ImageError, ProgramImage
from asictl.source import symbols_path


def uploaded_files(image: ProgramImage, output: str | Path) -> list[tuple[Path, bytes]]:
    """(path, exact bytes) of every file an upload to ``output`` writes, main first, the
    symbol table (if the image carries one) last.

    The block files' names come from the image, which anyone can craft: each must be a
    plain, printable file name (no folder, no NUL, no escape sequence that would drive
    the terminal it is printed on), or nothing is written.
    """
    output = Path(output)
    sources = image.program_sources()
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
    table = image.symbols()
    if table is not None:
        files.append((symbols_path(output), table[1]))
    targets = [real_path(path) for path, _ in files]
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


def uploaded_source(image: ProgramImage) -> str:
    """IL source text for an image without source: its settings, and itself as [RAW]."""
    options = image.options
    module = ast.Module(
        file="",
        sections=(
            ast.OptionsSection(tuple(ast.Option(n, v) for n, v in options.values().items())),
            ast.SetupSection(tuple(
                ast.SlaveSetup(s.address, s.io_code, s.id_code, s.parameter)
                for s in image.configuration.slaves()
            )),
            ast.RawSection(tuple(image.to_hex().splitlines())),
        ),
    )
    why = "it did not fit in the EEPROM" if image.source_left_out else "it was left out"
    return (
        f"; Uploaded program {image.identity_hex}: the image carries no source text ({why}).\n"
        "; [OPTIONS] and [SETUP] describe the image; [RAW] is the image itself, and\n"
        "; downloading this file writes it back unchanged.\n"
        "\n" + module.to_source()
    )
