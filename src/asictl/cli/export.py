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
    from asictl.export.awl import AwlProgram
    from asictl.il.loader import Program

#: The formats, as --to names them.
FORMATS = ("awl",)


@click.command("export")
@click.argument("source", metavar="FILE.asi")
@click.option("--to", "to", required=True, type=click.Choice(FORMATS),
              help="The language to export to: awl (S7 STL, as awlsim runs it).")
@click.option("-o", "--output", type=click.Path(dir_okay=False),
              help="Write here [default: FILE.awl beside the source]; - for stdout "
                   "(then without the map file).")
@click.option("--check", is_flag=True,
              help="Run the AWL in awlsim against the scenario FILE.scenario.toml (if there "
                   "is one) and generated input sequences, cycle by cycle beside the "
                   "master's semantics.")
@click.option("--sequences", type=click.IntRange(0), default=1000, show_default=True,
              help="How many generated input sequences --check runs.")
@click.option("--seed", type=int, default=1, show_default=True,
              help="The seed of the generated sequences.")
@click.option("--awlsim-python", metavar="PYTHON",
              help="The Python with awlsim 0.77.1 [default: $ASICTL_AWLSIM_PYTHON, else the "
                   "one beside awlsim-test on PATH].")
@lib_option
def export(source: str, to: str, output: str | None, check: bool, sequences: int,
           seed: int, awlsim_python: str | None, lib: tuple[str, ...]) -> None:
    """Export the IL program FILE.asi to S7 STL (AWL) for the PLC that replaces the master.

    Writes OB 1 with the program, an FC per function block, OB 100 and the data blocks,
    and beside it OUT.map.json: every input, output and flag the program uses, as
    written in IL (and by symbol), with its S7 address; and OUT.sym.csv, the symbol
    table in awlsim's CSV form. Timers keep the master's 10 ms tick exactly
    (at cycle times that are multiples of 10 ms). What has no S7 equivalent (the
    master's firmware blocks, PARAM, [ASSEMBLY] lines) is listed on standard error as
    FILE:LINE: ... and marked TODO in the code. The files are written whole or not at
    all. A program with errors is refused, as compile refuses it.

    --check runs the result in awlsim (an S7 simulator, installed apart, see
    docs/migrate.md) beside asictl's own semantics and names the first difference.

    Exit status: 0 exported (and checked: no difference), 1 errors in the program,
    something left for a person, or a difference, 2 bad usage or an unreadable file.

    Example: asictl export demos/sequence.asi --to awl --check
    """
    from asictl.build import build_file
    from asictl.export.awl import export_awl
    from asictl.observe.symbols import symbols_for

    ctx = click.get_current_context()
    built = build_file(source, lib=lib)
    click.echo(built.render(colour=stderr_colour()), nl=False, err=True)
    if built.has_errors or built.program is None or built.image is None:
        ctx.exit(int(ExitCode.FAILED))
    program = built.program
    exported = export_awl(Path(built.name).name, program)
    text = exported.render()
    target = output or str(Path(source).with_suffix(".awl"))
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
    for left in exported.unfinished:
        click.echo(f"{left}: left for a person", err=True)
    failed = bool(exported.unfinished)
    if check:
        failed = not _check(source, program, exported, sequences, seed, awlsim_python) or failed
    if failed:
        ctx.exit(int(ExitCode.FAILED))


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
