"""Loading a program: the main file and the function-block files it calls.

The manual (3.3) says a function block's file "will only be processed if the function
block is called", so files are read by following calls from the main program, not by
reading every declaration. A block's file is looked up next to the file that declares it,
then along the library path (``--lib`` options, then ``ASICTL_LIB``, colon-separated).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from asictl.codes import CheckCode
from asictl.diagnostics import Diagnostic, Reporter
from asictl.errors import UserError
from asictl.il import ast
from asictl.il.parser import parse
from asictl.platform.master import Options
from asictl.runtime.firmware import FIRMWARE_BLOCKS
from asictl.source import SourceText, read_source


@dataclass
class Program:
    """A main module and every user function block reachable from it by calls."""

    main: ast.Module
    #: key(name) -> the block's module, for every user block that is called and could be read
    blocks: dict[str, ast.Module] = field(default_factory=dict)
    #: file name -> its text, for diagnostics and for images that carry their source
    sources: dict[str, SourceText] = field(default_factory=dict)
    #: key(name) -> declaration, over all modules
    fb_decls: dict[str, ast.FBDecl] = field(default_factory=dict)

    def modules(self) -> list[ast.Module]:
        return [self.main, *self.blocks.values()]

    @property
    def options(self) -> Options:
        """The main file's [OPTIONS], the manual's defaults for what they leave out."""
        return Options.from_values({
            ast.key(o.name): o.value
            for section in self.main.sections_of(ast.OptionsSection)
            for o in section.options
        })

    @property
    def slaves(self) -> list[ast.SlaveSetup]:
        """The slaves all [SETUP] sections of the main file project."""
        return [s for section in self.main.sections_of(ast.SetupSection) for s in section.slaves]


def library_path(extra: Iterable[str | Path] = ()) -> list[Path]:
    paths = [Path(p) for p in extra]
    env = os.environ.get("ASICTL_LIB", "")
    paths.extend(Path(p) for p in env.split(os.pathsep) if p)
    return paths


def find_block_file(
    name: str, declared_in: str, search: Sequence[Path],
    exists: Callable[[Path], bool] = Path.is_file,
) -> Path | None:
    """Where a block's source is: next to the declaring file, then on the library path.

    DOS file names are case-insensitive, so ``MEAN.FB`` finds ``mean.fb``. ``exists`` lets
    an editor count its unsaved buffers as files.
    """
    base = Path(declared_in).parent if declared_in not in ("<stdin>", "<string>") else Path()
    for folder in (base, *search):
        candidate = folder / name
        if exists(candidate):
            return candidate
        try:
            for entry in folder.iterdir():
                if entry.name.casefold() == Path(name).name.casefold() and entry.is_file():
                    return entry
        except OSError:
            continue
    return None


def fb_declarations(module: ast.Module) -> list[ast.FBDecl]:
    return [
        d
        for section in module.sections_of(ast.DeclSection)
        for d in section.declarations
        if isinstance(d, ast.FBDecl)
    ]


def calls(module: ast.Module) -> list[ast.CallFB]:
    return [s for s in module.statements() if isinstance(s, ast.CallFB)]


#: How the loader reads a block's file; an editor passes one that prefers its open buffers.
Reader = Callable[[Path], SourceText]


def load_program(
    source: SourceText, *, lib: Iterable[str | Path] = (), read: Reader = read_source,
    exists: Callable[[Path], bool] = Path.is_file,
) -> tuple[Program, list[Diagnostic]]:
    """Parse the main file and every block file it reaches; report what cannot be read.

    Undeclared blocks and recursion are left to the semantic checks, which see the whole
    program; here only missing and unreadable files are reported, at the call that needs them.
    ``read`` and ``exists`` stand for the file system (see ``find_block_file``).
    """
    report = Reporter()
    main, diags = parse(source)
    report.extend(diags)
    program = Program(main=main, sources={source.name: source})
    search = library_path(lib)

    pending = [main]
    while pending:
        module = pending.pop()
        for declared in fb_declarations(module):
            program.fb_decls.setdefault(ast.key(declared.name), declared)
        for call in calls(module):
            name = ast.key(call.name)
            decl = program.fb_decls.get(name)
            if decl is None or name in program.blocks:
                continue
            if decl.span is None:  # a declaration always comes from a file
                continue
            path = find_block_file(decl.file, decl.span.file, search, exists)
            if path is None:
                report.error(
                    CheckCode.BLOCK_FILE_NOT_FOUND,
                    f"file '{decl.file}' of function block '{decl.name}' not found "
                    f"(looked next to {decl.span.file}"
                    + (" and in the library path" if search else "")
                    + ")",
                    decl.span,
                )
                program.blocks[name] = ast.Module(file=decl.file, sections=())
                continue
            try:
                text = read(path)
            except UserError as exc:
                report.error(
                    CheckCode.BLOCK_FILE_NOT_FOUND,
                    f"cannot read function block file: {exc}", decl.span)
                program.blocks[name] = ast.Module(file=str(path), sections=())
                continue
            block, diags = parse(text)
            report.extend(diags)
            program.sources[text.name] = text
            program.blocks[name] = block
            pending.append(block)
    return program, report.diagnostics


def is_firmware_block(name: str) -> bool:
    return ast.key(name) in FIRMWARE_BLOCKS
