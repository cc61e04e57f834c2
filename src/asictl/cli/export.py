"""``asictl export``: a program as S7 STL (AWL) for the PLC that replaces the master
(docs/migrate.md), and the check that it behaves the same in awlsim."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import click

from asictl.cli.options import lib_option
from asictl.cli.terminal import stderr_colour
from asictl.errors import ExitCode, UserError
from asictl.files import refuse_inputs, write_stdout, write_together

if TYPE_CHECKING:
    from collections.abc import Sequence

    from asictl.export.awl import AwlProgram
    from asictl.export.gaps import Unfinished
    from asictl.il.loader import Program

#: The formats, as --to names them.
FORMATS = ("awl", "st", "plcopen")
#: The file name ending of each format's output.
_SUFFIX = {"awl": ".awl", "st": ".st", "plcopen": ".xml"}


@click.command("export")
@click.argument("source", metavar="FILE.asi")
@click.option("--to", "to", required=True, type=click.Choice(FORMATS),
              help="The language: awl (S7 STL, as awlsim runs it), st (IEC 61131-3 "
                   "Structured Text) or plcopen (the same as PLCopen TC6 XML).")
@click.option("-o", "--output", type=click.Path(dir_okay=False),
              help="Write here [default: FILE.awl, FILE.st or FILE.xml beside the source]; - for "
                   "stdout (then without the map and symbol files).")
@click.option("--check", is_flag=True,
              help="awl: run it in awlsim against the scenario FILE.scenario.toml (if there "
                   "is one) and generated input sequences, cycle by cycle beside the "
                   "master's semantics; st: parse it with blark; plcopen: validate it against "
                   "the TC6 schema ($ASICTL_TC6_XSD).")
@click.option("--sequences", type=click.IntRange(0), default=1000, show_default=True,
              help="How many generated input sequences --check runs.")
@click.option("--seed", type=int, default=1, show_default=True,
              help="The seed of the generated sequences.")
@click.option("--awlsim-python", metavar="PYTHON",
              help="The Python with awlsim 0.77.1 [default: $ASICTL_AWLSIM_PYTHON, else the "
                   "one beside awlsim-test on PATH].")
@click.option("--blark", metavar="PROGRAM",
              help="blark 0.8.3's script [default: $ASICTL_BLARK, else blark on PATH].")
@lib_option
def export(source: str, to: str, output: str | None, check: bool, sequences: int,
           seed: int, awlsim_python: str | None, blark: str | None,
           lib: tuple[str, ...]) -> None:
    """Export the IL program FILE.asi for the PLC that replaces the master: S7 STL (AWL),
    IEC 61131-3 Structured Text (ST) or the same as PLCopen TC6 XML.

    awl: OB 1 with the program, an FC per function block, OB 100 and the data blocks,
    and beside it OUT.map.json: every input, output and flag the program uses, as
    written in IL (and by symbol), with its S7 address; and OUT.sym.csv, the symbol
    table in awlsim's CSV form. st: one PROGRAM and a FUNCTION_BLOCK per function block,
    the operands as located variables named by the program's symbols, each IL line as a
    comment above what it became. plcopen: those POUs in PLCopen TC6 XML 2.01.

    Timers keep the master's 10 ms tick exactly (at cycle times that are multiples of
    10 ms). What has no equivalent (the master's firmware blocks, PARAM, [ASSEMBLY]
    lines) is listed on standard error as FILE:LINE: ... and marked TODO in the code.
    The files are written whole or not at all. A program with errors is refused, as
    compile refuses it.

    --check runs the AWL in awlsim (an S7 simulator, installed apart, see
    docs/migrate.md) beside asictl's own semantics and names the first difference; for
    ST it parses the result with blark, for PLCopen it validates the XML against the TC6
    schema.

    Exit status: 0 exported (and checked: no difference), 1 errors in the program,
    something left for a person, or a difference, 2 bad usage or an unreadable file.

    \b
    Examples:
      asictl export demos/sequence.asi --to awl --check --sequences 100
      asictl export demos/jump.asi --to st -o jump.st
    """
    from asictl.build import build_file

    ctx = click.get_current_context()
    built = build_file(source, lib=lib)
    click.echo(built.render(colour=stderr_colour()), nl=False, err=True)
    if built.has_errors or built.image is None:
        ctx.exit(int(ExitCode.FAILED))
    program = built.source_program()
    if program is None:
        raise UserError(f"{source}: no IL program text to export (an image or a [RAW] "
                        "upload without its source)")
    target = output or str(Path(source).with_suffix(_SUFFIX[to]))
    if to in ("st", "plcopen"):
        failed = _export_iec(source, program, target, built.name, check, blark, to == "plcopen")
    else:
        failed = _export_awl(source, program, target, built.name, check,
                             (sequences, seed, awlsim_python))
    if failed:
        ctx.exit(int(ExitCode.FAILED))


def _export_awl(source: str, program: Program, target: str, name: str, check: bool,
                campaign: tuple[int, int, str | None]) -> bool:
    """Write the AWL, its map and its symbol table; True when something failed."""
    from asictl.export.awl import export_awl
    from asictl.observe.symbols import symbols_for

    exported = export_awl(Path(name).name, program)
    text = exported.render()
    if target == "-":
        write_stdout(text)
    else:
        symbols = symbols_for(source)
        the_map = str(Path(target).with_suffix(".map.json"))
        table = str(Path(target).with_suffix(".sym.csv"))
        for path in (target, the_map, table):
            refuse_inputs(path, [source, *program.sources])
        named = {name: exported.operands[operand] for name, operand in symbols.entries.values()
                 if operand in exported.operands}
        operands = json.dumps({"operands": {**exported.operands, **named}}, indent=2) + "\n"
        write_together([(target, text), (the_map, operands),
                        (table, exported.symbol_table(symbols))])
        click.echo(f"{target}: {len(exported.blocks)} blocks; {the_map}: "
                   f"{len(exported.operands)} operands; {table}", err=True)
    _report(exported.unfinished)
    agreed = _check(source, program, exported, *campaign) if check else True
    return bool(exported.unfinished) or not agreed


def _export_iec(source: str, program: Program, target: str, name: str, check: bool,
                blark: str | None, xml: bool) -> bool:
    """Write the Structured Text, or it as PLCopen XML; True when something failed."""
    from asictl.export.check import blark_parse
    from asictl.export.plcopen import plcopen_xml, validate
    from asictl.export.st import export_st
    from asictl.observe.symbols import symbols_for

    exported = export_st(Path(name).name, program, symbols_for(source))
    text = plcopen_xml(exported) if xml else exported.render()
    if target == "-":
        write_stdout(text)
    else:
        refuse_inputs(target, [source, *program.sources])
        write_together([(target, text)])
        click.echo(f"{target}: {len(exported.pous)} POUs, {len(exported.variables)} located "
                   "variables", err=True)
    _report(exported.unfinished)
    complaint = None
    if check and xml:
        complaint = validate(text)
        click.echo(f"TC6 schema: {'not valid' if complaint else 'valid'}")
    elif check:
        complaint = blark_parse(text, blark)
        click.echo(f"blark: {'does not parse' if complaint else 'parses'} the Structured Text")
    if complaint:
        click.echo(complaint, err=True)
    return bool(exported.unfinished) or complaint is not None


def _report(unfinished: Sequence[Unfinished]) -> None:
    for left in unfinished:
        click.echo(f"{left}: left for a person", err=True)


def _check(source: str, program: Program, exported: AwlProgram, sequences: int, seed: int,
           python: str | None) -> bool:
    """Run the checks, a line each; True when awlsim and the master agreed throughout."""
    from asictl.export.check import Awlsim, Checker, awlsim_python, generated_runs, scenario_run
    from asictl.observe.symbols import symbols_for
    from asictl.sim.session import Invalid, prepare

    runs = []
    scenario = Path(source).with_suffix(".scenario.toml")
    if source != "-" and scenario.is_file():
        try:
            prepared = prepare(Path(source), scenario)
        except Invalid as exc:
            click.echo(exc.text, nl=False, err=True)
            raise UserError(f"{scenario}: {exc.message}") from None
        runs.append((f"scenario {scenario}", [(str(scenario), scenario_run(prepared))]))
    runs.append((f"{sequences} generated input sequences (seed {seed})",
                 list(generated_runs(sequences, seed))))
    agreed = True
    symbols = exported.symbol_table(symbols_for(source))
    with Awlsim(exported.render(), awlsim_python(python), symbols) as awlsim:
        checker = Checker(program, exported, awlsim)
        for title, named in runs:
            cycles = 0
            for name, run in named:
                difference = checker.compare(name, run)
                if difference is not None:
                    click.echo(f"{title}: first difference: {difference}")
                    agreed = False
                    break
                cycles += len(run)
            else:
                click.echo(f"{title}: {cycles} cycles in awlsim, 0 differences")
    return agreed
