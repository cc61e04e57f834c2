"""``asictl record``: a running master's inputs and outputs over time, as a scenario."""

from __future__ import annotations

import math
import os
import signal
import tempfile
import time
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TextIO, Unpack

import click

from asictl.cli.board_options import BoardOptions, board_options, open_master
from asictl.cli.options import Duration, Number
from asictl.diagnostics import printable
from asictl.errors import ExitCode, UserError
from asictl.files import open_atomic, real_path
from asictl.host.master import Master
from asictl.host.status import MasterStatus, StoredProgram
from asictl.readers.units import format_duration
from asictl.sim import SUFFIX
from asictl.sim.recording import Recording, choose, slave_operands

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

    The master is read as often as it answers, for --duration, and each change goes to
    disk at once (memory stays the same however long it records). Ctrl-C, SIGTERM or
    SIGHUP end the recording early, and so does a board that stops answering: what was
    recorded is written all the same, a whole scenario, and the message says what ended
    it. Replay it with 'asictl sim PROGRAM --scenario
    OUTPUT': the unchanged program passes, a changed one fails at the first expectation
    where it behaves otherwise, naming the IL line that last wrote the operand.

    Exit status: 0 recorded (also when ended early by Ctrl-C or a signal), 1 the master
    did not answer (or stopped answering: what came before is written), 2 bad usage.

    \b
    Examples:
      asictl download demos/blink.asi --start
      asictl record --duration 2s -o run.scenario.toml --tolerance-ms 50
    """
    seconds = duration / 1000
    if output.is_file() and not force:
        raise UserError(f"{output}: exists; not overwritten (use --force)")
    patterns = [p for p in signals.split(",") if p.strip()] if signals else None
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
    click.echo(printable(f"asictl: recording {read.name} for "
                         f"{format_duration(seconds * 1000)}: {len(inputs)} inputs, "
                         f"{len(expected)} outputs and flags (Ctrl-C ends it early)"),
               err=True)
    with _spool(output) as spool:
        recording = Recording(inputs, expected, spool)
        ended = _sample(read, recording, names, seconds)
        if ended is not None:
            click.echo(printable(f"asictl: recording ended early: {ended}"), err=True)
        if not recording.count:
            raise UserError(f"{read.name}: no sample in {format_duration(duration)}"
                            + (f" ({ended})" if ended else ""))
        with _held():  # the file is written whole, whatever signal comes now
            _write(recording, output, tolerance_ms, program, read.name)
    every = recording.every_ms
    click.echo(printable(f"asictl: {output}: {recording.count} samples over "
                         f"{format_duration(recording.span_ms)} (one every "
                         f"{format_duration(every)}), "
                         f"{len(inputs)} inputs and {len(expected)} outputs and flags "
                         "recorded"), err=True)
    if ended is not None and ended.startswith("the board"):
        raise UserError(f"{read.name}: the recording ended early: {ended}", ExitCode.FAILED)


class _Ended(Exception):
    """A signal that ends a recording (SIGTERM, SIGHUP): what was recorded is kept."""


#: The signals that end a recording as Ctrl-C does (where the platform has them).
_ENDING = [getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)]


def _sample(read: _Reader, recording: Recording, names: set[str], seconds: float
            ) -> str | None:
    """Sample until ``seconds`` have passed (None) or something ends the recording
    early (what it was: Ctrl-C, a signal, the board gone); every sample goes to the
    recording's spool at once."""
    def end(number: int, _frame: object) -> None:
        raise _Ended(signal.Signals(number).name)

    before = {number: signal.signal(number, end) for number in _ENDING}
    started = time.monotonic()
    try:
        while True:
            ask = time.monotonic()
            try:
                data = read()
            except (UserError, OSError) as exc:
                if not recording.count:
                    raise
                return f"the board stopped answering ({exc})"
            at = (ask + time.monotonic()) / 2 - started
            if at > seconds:
                return None
            recording.add(at * 1000, data.values(names))
    except KeyboardInterrupt:
        return "Ctrl-C"
    except _Ended as exc:
        return str(exc)
    finally:
        for number, handler in before.items():
            signal.signal(number, handler)


@contextmanager
def _spool(output: Path) -> Iterator[TextIO]:
    """The steps of a recording on disk as it goes: a file without a name beside the
    output (it vanishes with the process, however it ends), else in the temporary
    folder."""
    folder = output.parent if output.parent.is_dir() else None
    try:
        # opened here to report its failure plainly, closed by the with below
        spool = tempfile.TemporaryFile("w+", encoding="utf-8", dir=folder)  # noqa: SIM115
    except OSError as exc:
        raise UserError(f"{output}: cannot record beside it: {exc.strerror or exc}") from None
    with spool:
        yield spool


@contextmanager
def _held() -> Iterator[None]:
    """Ctrl-C, SIGTERM and SIGHUP wait while the scenario is written (it takes a moment
    after hours of recording), and take effect after it."""
    caught: list[int] = []
    numbers = [signal.SIGINT, *_ENDING]
    before = {n: signal.signal(n, lambda number, _frame: caught.append(number))
              for n in numbers}
    try:
        yield
    finally:
        for number, handler in before.items():
            signal.signal(number, handler)
    if caught:
        click.echo(f"asictl: {signal.Signals(caught[0]).name} came while the scenario was "
                   "written; it is whole", err=True)


def _write(recording: Recording, output: Path, tolerance_ms: float | None,
           program: Path | None, name: str) -> None:
    span, every = recording.span_ms, recording.every_ms
    if tolerance_ms is None:  # a change is seen up to a sample late, its effect too
        tolerance_ms = max(DEFAULT_TOLERANCE_MS, math.ceil(2 * every / 10) * 10)
    when = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    named = None
    if program is not None:
        named = str(Path(_relative(real_path(program), real_path(output).parent)))
    comment = (f"Recorded by asictl record from {name} at {when}: {format_duration(span)}, "
               f"{recording.count} samples (one every {format_duration(every)} on average).\n"
               f"Replay: asictl sim {program or 'PROGRAM'} --scenario {output}")
    with open_atomic(output, inputs=[program] if program else []) as out:
        recording.write(out, tolerance_ms, program=named, comment=comment)


def _relative(path: Path, folder: Path) -> Path:
    """``path`` relative to ``folder`` where it can be, else as it is."""
    try:
        return path.relative_to(folder)
    except ValueError:
        return Path(os.path.relpath(path, folder))
