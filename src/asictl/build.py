"""The one build pipeline: any program file -> checked program, image and diagnostics.

Every command that takes a program (check, compile, download, verify, sim, test, debug,
the gateway's download) comes through here, so each accepts the same inputs and reports
the same diagnostics. A program file is one of:

- IL source with the function-block files it calls: checked (what ``asictl check``
  reports), compiled against the firmware entry points of the master it is meant for,
  and made into an image;
- an uploaded file whose program is a [RAW] section: the image is its records, and its
  [OPTIONS] and [SETUP] must describe that image;
- an Intel HEX image written by ``asictl compile``.

A source file goes down the pipeline once and never back up:
build -> il (parse, load, check) -> codegen8051 (allocate, generate, assemble) -> image.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING

from asictl.codes import CompileCode, ImageCode
from asictl.diagnostics import Diagnostic, DiagnosticError, Severity, Span, render_text
from asictl.errors import ExitCode
from asictl.il import ast
from asictl.il.checks import Dialect, check_source
from asictl.il.loader import Program
from asictl.platform.master import EEPROM_SIZE, Options
from asictl.source import SourceText, from_bytes, read_source, symbols_path

# The image format (and the runtime contract it describes) and the compiler are imported
# by the functions that use them: checking a source file, what ``asictl check`` does most,
# needs neither, and loading them would add some 20 ms to every check.
if TYPE_CHECKING:
    from asictl.codegen8051.compiler import Compiled
    from asictl.image.eeprom import ProgramImage, SlaveConfig

#: An Intel HEX record: colon, count, address, type, data, checksum.
_HEX_RECORD = re.compile(r":(?:[0-9A-Fa-f]{2}){5,}")


class Stage(StrEnum):
    """The steps of ``build``, reported as each ends (for a verbose log)."""

    CHECKED = "checked"
    COMPILED = "compiled"
    IMAGE = "image"


class Origin(StrEnum):
    """What a program file holds."""

    SOURCE = "source"
    RAW = "raw"
    HEX = "hex"


@dataclass
class Build:
    """What the pipeline made of one program file (``image`` is None where it stopped)."""

    name: str
    origin: Origin
    diagnostics: list[Diagnostic] = field(default_factory=list)
    #: file name -> text, to show diagnostics with their source lines
    texts: dict[str, str] = field(default_factory=dict)
    #: the checked program of a source or [RAW] file
    program: Program | None = None
    #: the code generator's output, for a source file
    compiled: Compiled | None = None
    image: ProgramImage | None = None

    @property
    def has_errors(self) -> bool:
        return any(d.is_error for d in self.diagnostics)

    def render(self, *, colour: bool = False) -> str:
        """The diagnostics as ``asictl check`` prints them (``colour``: for a terminal)."""
        return render_text(self.diagnostics, self.texts, colour=colour)

    def source_program(self) -> Program | None:
        """The IL program the image was compiled from, where it is known: a source file's
        own, else the source an image carries (None for an image without source)."""
        if self.origin is Origin.SOURCE:
            return self.program
        return program_of_image(self.image) if self.image is not None else None


def is_hex(text: str) -> bool:
    """Intel HEX text: its first line is a whole record (no IL line can be one)."""
    first = text.lstrip().partition("\n")[0]
    return _HEX_RECORD.fullmatch(first.strip()) is not None


def check(
    source: SourceText, *, dialect: Dialect = Dialect.CONTROL2, lib: Iterable[str | Path] = ()
) -> Build:
    """What ``asictl check`` reports: the front end's diagnostics, and for an uploaded file
    whether its [RAW] image is sound. Nothing is compiled."""
    if is_hex(source.text):
        from asictl.image.eeprom import ProgramImage

        return Build(source.name, Origin.HEX, image=ProgramImage.from_hex(source.text))
    result = check_source(source, dialect=dialect, lib=lib)
    program = result.program
    texts = {name: s.text for name, s in program.sources.items()}
    built = Build(source.name, Origin.SOURCE, list(result.diagnostics), texts, program)
    if program.main.sections_of(ast.RawSection):
        built.origin = Origin.RAW
        if not result.has_errors:
            built.image, raw_diagnostics = _raw_image(program)
            built.diagnostics.extend(raw_diagnostics)
    return built


def build(
    source: SourceText,
    *,
    lib: Iterable[str | Path] = (),
    entry_points: Mapping[str, int] | None = None,
    with_source: bool = True,
    on_stage: Callable[[Stage, Build], None] | None = None,
    symbols: bytes | None = None,
) -> Build:
    """Check, compile and make the image of a program file; ``entry_points`` are the
    firmware's of the master it is for (default: the runtime contract's table);
    ``symbols`` the raw symbol table the image carries with its source.

    Raises ``ImageError`` for an Intel HEX file that holds no valid image (unreadable
    input); everything else wrong with the program is in the diagnostics.
    """
    from asictl.codegen8051.compiler import GENERATED, compile_program
    from asictl.image.eeprom import ImageError

    report = on_stage or (lambda stage, built: None)
    built = check(source, lib=lib)
    report(Stage.CHECKED, built)
    if built.origin is not Origin.SOURCE or built.has_errors:
        return built
    assert built.program is not None
    try:
        compiled = compile_program(built.program, entry_points=entry_points)
    except DiagnosticError as exc:
        built.diagnostics.extend(exc.diagnostics)
        return built
    built.compiled = compiled
    built.texts[GENERATED] = compiled.assembly_text
    built.diagnostics.extend(compiled.diagnostics)
    report(Stage.COMPILED, built)
    try:
        built.image = build_image(compiled, with_source=with_source, symbols=symbols)
    except ImageError as exc:
        built.diagnostics.append(Diagnostic(Severity.ERROR, CompileCode.IMAGE_TOO_LARGE, str(exc)))
        return built
    report(Stage.IMAGE, built)
    return built


def build_file(
    path: str | Path,
    *,
    lib: Iterable[str | Path] = (),
    entry_points: Mapping[str, int] | None = None,
    with_source: bool = True,
    on_stage: Callable[[Stage, Build], None] | None = None,
) -> Build:
    """``build`` of the file at ``path`` ('-' is standard input), with the symbol table
    beside it (``NAME.symbols.toml``) when there is one: an image carries it with the
    source, so that a board shows and takes the program's names."""
    table = symbols_path(path) if str(path) != "-" else None
    symbols = read_source(table).raw if table is not None and table.is_file() else None
    return build(
        read_source(path), lib=lib, entry_points=entry_points, with_source=with_source,
        on_stage=on_stage, symbols=symbols,
    )


def build_image(
    compiled: Compiled, *, with_source: bool = True, symbols: bytes | None = None
) -> ProgramImage:
    """The image of a compiled program, with its source if wanted and if it fits, and
    the raw ``symbols`` table as the source container's last file (named after the main
    file: ``NAME.symbols.toml``).

    Raises ``ImageError`` when even the code and map exceed the EEPROM.
    """
    from asictl.image.eeprom import (
        HEADER_SIZE,
        Configuration,
        ImageError,
        ProgramImage,
        pack_sources,
        program_identity,
        source_files,
    )

    program = compiled.program
    files = source_files({name: s.raw for name, s in program.sources.items()})
    if symbols is not None and with_source:
        files.append((symbols_path(files[0][0]).name, symbols))
    image = ProgramImage(
        flags=compiled.options.control_flags(),
        configuration=Configuration.of(program.slaves),
        identity=program_identity(files),
        code=compiled.code,
        pmap=compiled.pmap,
        entry_points=compiled.used_entry_points(),
    )
    with_lines = replace(image, line_map=compiled.line_map)
    size = len(with_lines.to_bytes())
    if size <= EEPROM_SIZE:  # the line map goes before the source
        image = with_lines
    else:
        size = len(image.to_bytes())
    if size > EEPROM_SIZE:
        raise ImageError(
            f"image needs {size} bytes, the EEPROM holds {EEPROM_SIZE} "
            f"(code {len(image.code)}, program map {size - HEADER_SIZE - len(image.code)}, "
            f"header {HEADER_SIZE})",
            ExitCode.FAILED,
        )
    if not with_source:
        return image
    source = pack_sources(files)
    if size + len(source) > EEPROM_SIZE:
        return replace(image, source_left_out=True)
    return replace(image, source=source)


def program_of_image(image: ProgramImage) -> Program | None:
    """The program an image carries as source, read from the image alone (None without
    source, or if that source no longer reads cleanly)."""
    sources = image.program_sources()
    if not sources:
        return None
    texts = {Path(name).name.casefold(): from_bytes(name, raw) for name, raw in sources.items()}
    main = next(iter(texts.values()))
    result = check_source(
        main,
        read=lambda path: texts[path.name.casefold()],
        exists=lambda path: path.name.casefold() in texts,
    )
    return None if result.has_errors else result.program


# ----------------------------------------------------------------------- uploaded files


def image_from_raw(records: Iterable[str]) -> ProgramImage:
    """The image an upload wrote as [RAW] records; ``to_bytes`` gives it back unchanged."""
    from asictl.image.eeprom import ProgramImage

    return ProgramImage.from_hex("\n".join(records) + "\n")


def _raw_image(program: Program) -> tuple[ProgramImage | None, list[Diagnostic]]:
    """The image of an uploaded file, whose [OPTIONS] and [SETUP] must describe its [RAW].

    The [RAW] records are what gets downloaded; a file whose other sections were edited
    would silently download something other than it says, so a mismatch is an error.
    """
    from asictl.image.eeprom import Configuration, ImageError

    module = program.main
    sections = module.sections_of(ast.RawSection)
    where = sections[0].span or Span(module.file, 1, 1)
    records = [r for section in sections for r in section.records]
    try:
        image = image_from_raw(records)
    except ImageError as exc:
        problem = Diagnostic(Severity.ERROR, ImageCode.RAW_INVALID, f"[RAW] section: {exc}", where)
        return None, [problem]
    problems = []
    if module.sections_of(ast.OptionsSection):
        wanted = program.options
        problems += [
            f"[OPTIONS] {name}: {_yes(getattr(wanted, name))}, "
            f"the image has {_yes(getattr(image.options, name))}"
            for name in Options.NAMES
            if getattr(wanted, name) != getattr(image.options, name)
        ]
    if module.sections_of(ast.SetupSection):
        wanted_slaves = {s.address: s for s in Configuration.of(program.slaves).slaves()}
        image_slaves = {s.address: s for s in image.configuration.slaves()}
        for n in sorted(wanted_slaves.keys() | image_slaves.keys()):
            if wanted_slaves.get(n) != image_slaves.get(n):
                problems.append(
                    f"[SETUP] slave {n}: {_setup_text(wanted_slaves.get(n))}, "
                    f"the image has {_setup_text(image_slaves.get(n))}"
                )
    if problems:
        return None, [Diagnostic(
            Severity.ERROR, ImageCode.RAW_MISMATCH,
            "the [OPTIONS] and [SETUP] sections do not match the [RAW] image they describe: "
            + "; ".join(problems),
            where,
        )]
    return image, []


def _yes(value: bool) -> str:
    return "yes" if value else "no"


def _setup_text(slave: SlaveConfig | None) -> str:
    if slave is None:
        return "not set up"
    return ast.SlaveSetup(
        slave.address, slave.io_code, slave.id_code, slave.parameter
    ).to_source().partition(": ")[2]
