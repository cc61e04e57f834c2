"""``asictl asm`` and ``asictl disasm``: the 8051 assembler and disassembler on files."""

from __future__ import annotations

from pathlib import Path

import click

from asictl.cli.hex_images import code_hex, describe, program_image
from asictl.diagnostics import DiagnosticError, render_text
from asictl.errors import ExitCode, UserError
from asictl.files import refuse_inputs, write_output
from asictl.mcs51.assembler import assemble, load_relative
from asictl.mcs51.disassembler import disassemble
from asictl.mcs51.hexfile import read_hex
from asictl.source import SourceText, read_source

_OUTPUT = click.Path(dir_okay=False, writable=True)


@click.command()
@click.argument("source", metavar="FILE.a51")
@click.option("-o", "--output", type=_OUTPUT, help="Intel HEX file to write [default: FILE.hex].")
@click.option("--listing", type=_OUTPUT, help="Also write a listing (address, code, source).")
@click.option("--symbols", type=_OUTPUT, help="Also write the symbol table.")
def asm(source: str, output: str | None, listing: str | None, symbols: str | None) -> None:
    """Assemble 8051 source FILE.a51 (Intel ASM51 or as31 syntax) into Intel HEX.

    The HEX file goes next to the source unless -o names another; use -o when reading
    standard input (-). Problems are reported as file:line:col: error: message [code]
    with the source line and a caret. If there is any error, no file is written.
    Output files are replaced in one step, never left half-written; an input file is
    never replaced, and a device such as /dev/null is written to, not replaced.

    Exit status: 0 assembled, 1 assembly errors, 2 bad usage or an unreadable file.

    \b
    Examples:
      asictl compile demos/blink.asi -o blink.hex
      asictl disasm blink.hex -o blink.a51
      asictl asm blink.a51 -o again.hex --listing again.lst
    """
    if source == "-" and output is None:
        raise click.UsageError("reading standard input needs -o FILE.hex")
    main_source = read_source(source)
    texts = {main_source.name: main_source.text}

    def include(name: str, including: SourceText) -> SourceText:
        loaded = load_relative(name, including)
        texts[loaded.name] = loaded.text
        return loaded

    try:
        result = assemble(main_source, include=include)
    except DiagnosticError as exc:
        click.echo(render_text(exc.diagnostics, texts), nl=False, err=True)
        click.get_current_context().exit(int(ExitCode.FAILED))
    click.echo(render_text(result.diagnostics, texts), nl=False, err=True)
    inputs = list(texts)
    write_output(output or Path(source).with_suffix(".hex"), result.to_hex(), inputs=inputs)
    if listing:
        write_output(listing, result.listing_text(), inputs=inputs)
    if symbols:
        write_output(symbols, result.symbol_table_text(), inputs=inputs)


@click.command()
@click.argument("image", metavar="FILE.hex")
@click.option("-o", "--output", type=_OUTPUT, help="Write the source here [default: stdout].")
@click.option("--force", is_flag=True, help="Overwrite an existing -o file.")
def disasm(image: str, output: str | None, force: bool) -> None:
    """Disassemble an Intel HEX image (- for stdin) into 8051 source.

    The source reassembles with 'asictl asm' to exactly the same bytes: gaps become
    ORG, the undefined opcode A5h and instructions cut off at the end of a memory range
    become DB, and jump targets get labels. Every byte is decoded as code; tables in
    the image show up as (harmless, exact) instructions.

    An image written by 'asictl compile' (an asictl program image) is recognised: its
    code is disassembled at its link address, after its program map as comments; the
    header, program map and source are data and are left out, so the source reassembles
    to the image's code.

    An existing -o file is not overwritten without --force: it may be the source the
    image was assembled from.

    Exit status: 0 done, 2 bad usage, an unreadable or malformed HEX file, or an -o file
    that exists.

    \b
    Examples:
      asictl compile demos/blink.asi -o blink.hex
      asictl disasm blink.hex -o blink.a51
    """
    hex_file = read_hex(image)
    for warning in hex_file.warnings:
        click.echo(f"asictl: warning: {warning}", err=True)
    hex_image = hex_file.image
    if hex_image.maxaddr() is not None and hex_image.maxaddr() > 0xFFFF:
        raise UserError(f"{image}: has bytes above FFFFh, outside the 8051 code space")
    program = program_image(hex_image, image)
    if program is None:
        text = disassemble(hex_image)
    else:
        text = "\n".join(describe(image, program)) + "\n\n" + disassemble(code_hex(program))
    if output:
        refuse_inputs(output, [image])
        if output != "-" and Path(output).is_file() and not force:
            raise UserError(f"{output}: exists; not overwritten (use --force)")
        write_output(output, text, inputs=[image])
    else:
        click.echo(text, nl=False)
