"""``asictl record``: a running master's inputs and outputs over time, as a scenario."""

from __future__ import annotations

import math
import os
import time
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Unpack

import click

from asictl.cli.board_options import BoardOptions, board_options, open_master
from asictl.cli.options import Duration, Number
from asictl.errors import UserError
from asictl.files import real_path, write_output
from asictl.host.master import Master
from asictl.host.status import MasterStatus, StoredProgram
from asictl.sim import SUFFIX
from asictl.sim.recording import Sample, choose, slave_operands, to_scenario

#: The default tolerance window of a recording's expectations.
DEFAULT_TOLERANCE_MS = 100


@dataclass(frozen=True)
class _Data:
    """One sample's data: each slave's input and output bits, the flag bytes."""

    inputs: Mapping[int, int]
    outputs: Mapping[int, int]
    flags: Sequence[int]

    @classmethod
    def of(cls, status: MasterStatus) -> _Data:
        slaves = {int(a): s for a, s in status.slaves.items()}
        return cls({a: s.inputs for a, s in slaves.items()},
                   {a: s.outputs for a, s in slaves.items()}, status.flags)

    def values(self, names: set[str]) -> dict[str, int]:
        values = {}
        for kind, data in (("I", self.inputs), ("Q", self.outputs)):
            for address, nibble in data.items():
                for bit in range(4):
                    name = f"{kind} {address}.{bit}"
                    if name in names:
                        values[name] = nibble >> bit & 1
        for byte, flags in enumerate(self.flags):
            for bit in range(8):
                name = f"F {byte}.{bit}"
                if name in names:
                    values[name] = flags >> bit & 1
        return values


class _Reader:
    """Reads the master, one connection a sample: a live board serves one session at a
    time, and the inputs must keep changing meanwhile (``asictl bus inputs``, a
    monitor). The first sample is the whole status (which slaves are there); then a PC2
    board's status without its EEPROM's program, a gateway's data registers alone."""

    def __init__(self, board: BoardOptions) -> None:
        self.board = board
        self.program: StoredProgram | None = None
        self.name = ""
        #: the flags are read only where they are recorded
        self.flags = True

    def first(self) -> MasterStatus:
        with self._master() as master:
            status = master.status()
            if master.quick_status is not None:
                self.program = StoredProgram(status.program)
            return status

    def __call__(self) -> _Data:
        with self._master() as master:
            quick = master.quick_status
            if quick is not None and self.program is not None:
                return _Data.of(quick(self.program))
            if master.driver is None:  # a gateway: three requests instead of a status
                from asictl.host.modbus_master import ModbusMaster, read_data

                if isinstance(master, ModbusMaster):
                    inputs, outputs, flags = read_data(master.transport, flags=self.flags)
                    return _Data(dict(enumerate(inputs)), dict(enumerate(outputs)), flags)
            return _Data.of(master.status())

    @contextmanager
    def _master(self) -> Iterator[Master]:
        with open_master(**self.board) as master:
            self.name = master.name
            if master.action is not None and master.action.live is None:
                raise UserError(
                    f"{master.name}: this emulated board runs only while a command holds "
                    "it, so nothing would change: serve it first ('asictl serve --port "
                    f"{self.board['port']}')"
                )
            yield master


@click.command("record")
@board_options
@click.option("--duration", required=True, type=Duration(limit_ms=24 * 3_600_000, positive=True),
              help="How long to record, e.g. 60s, 2m (at most 24h).")
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help=f"The scenario to write (NAME{SUFFIX}).")
@click.option("--force", is_flag=True, help="Replace the output file if it exists.")
@click.option("--signals", help='What to record: comma-separated shell patterns over I a.b, '
              'Q a.b and F y.b, e.g. "I 4.*,Q 17.*,F 0.0" (default: every input and output '
              "of the slaves on the bus).")
@click.option("--tolerance-ms", type=Number(0, 60_000),
              help="The expectations' tolerance window (within_ms): a change may come this "
              f"much earlier or later in a replay [default: {DEFAULT_TOLERANCE_MS} ms, or twice "
              "the sampling interval if that is longer].")
@click.option("--program", "program", type=click.Path(dir_okay=False, path_type=Path),
              help="Name this program in the scenario ('program = ...', relative to it).")
def record(duration: float, output: Path, force: bool, signals: str | None,
           tolerance_ms: float | None, program: Path | None,
           **board: Unpack[BoardOptions]) -> None:
    """Record a running master (a served emulated board, a real board or a gateway) as
    a scenario: its input changes become set steps, its output changes (and those of the
    flags --signals chooses) expectations with a tolerance window.

    The master is read as often as it answers, for --duration; Ctrl-C ends the recording
    early and writes what was recorded. Replay it with 'asictl sim PROGRAM --scenario
    OUTPUT': the unchanged program passes, a changed one fails at the first expectation
    where it behaves otherwise, naming the IL line that last wrote the operand.

    Exit status: 0 recorded, 1 the master did not answer, 2 bad usage.

    \b
    Examples:
      asictl download demos/blink.asi --start
      asictl record --duration 2s -o run.scenario.toml --tolerance-ms 50
    """
    seconds = duration / 1000
    if output.is_file() and not force:
        raise UserError(f"{output}: exists; not overwritten (use --force)")
    patterns = [p for p in signals.split(",") if p.strip()] if signals else None
    samples: list[Sample] = []
    read = _Reader(board)
    status = read.first()
    detected = {int(a): s.cdi for a, s in status.slaves.items() if int(a) in status.lds
                and int(a)}
    inputs, expected = choose(*slave_operands(detected), patterns)
    if not inputs and not expected:
        raise UserError("nothing to record: no slave on the bus"
                        + (f" matches --signals '{signals}'" if patterns else ""))
    names = {*inputs, *expected}
    read.flags = any(name.startswith("F") for name in names)
    click.echo(f"asictl: recording {read.name} for {seconds:g} s: {len(inputs)} inputs, "
               f"{len(expected)} outputs and flags (Ctrl-C ends it early)", err=True)
    started = time.monotonic()
    try:
        while True:
            before = time.monotonic()
            data = read()
            at = (before + time.monotonic()) / 2 - started
            if at > seconds:
                break
            samples.append(Sample(at * 1000, data.values(names)))
    except KeyboardInterrupt:
        click.echo("asictl: recording ended early (Ctrl-C)", err=True)
    name = read.name
    if not samples:
        raise UserError(f"{name}: no sample in {duration}")
    if samples[0].at_ms:
        first = samples[0].at_ms
        samples = [Sample(s.at_ms - first, s.values) for s in samples]
    span = samples[-1].at_ms
    every = span / max(1, len(samples) - 1)
    if tolerance_ms is None:  # a change is seen up to a sample late, its effect too
        tolerance_ms = max(DEFAULT_TOLERANCE_MS, math.ceil(2 * every / 10) * 10)
    when = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    named = None
    if program is not None:
        named = str(Path(_relative(real_path(program), real_path(output).parent)))
    comment = (f"Recorded by asictl record from {name} at {when}: {span / 1000:.1f} s, "
               f"{len(samples)} samples (one every {every:.0f} ms on average).\n"
               f"Replay: asictl sim {program or 'PROGRAM'} --scenario {output}")
    text = to_scenario(samples, inputs, expected, tolerance_ms, program=named, comment=comment)
    write_output(output, text, inputs=[program] if program else [])
    click.echo(f"asictl: {output}: {len(samples)} samples over {span / 1000:.1f} s "
               f"(one every {every:.0f} ms), {len(inputs)} inputs and {len(expected)} "
               "outputs and flags recorded", err=True)


def _relative(path: Path, folder: Path) -> Path:
    """``path`` relative to ``folder`` where it can be, else as it is."""
    try:
        return path.relative_to(folder)
    except ValueError:
        return Path(os.path.relpath(path, folder))
