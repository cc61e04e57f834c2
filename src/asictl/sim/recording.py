"""Recordings of a running master as scenarios: what ``asictl record`` writes.

A recording is a list of samples (a time and the values of the recorded operands). Its
scenario sets every input at time 0 and then each input change at the time it was first
seen, and expects each output and flag change at the time it was first seen, with a
tolerance window (``within_ms``, docs/simulation.md): a sample sees a change only some
time after it happened, and the master's cycle and the reading's own delays shift it
further, so a replay against the unchanged program passes while a program that behaves
otherwise fails at the first expectation where it differs.
"""

from __future__ import annotations

import fnmatch
import io
import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TextIO

from asictl.platform.master import IO_CODE_BITS
from asictl.sim.scenario_writer import ScenarioWriter

#: The number of flag bytes a recording may choose bits from.
FLAG_BYTES = 128


@dataclass(frozen=True)
class Sample:
    """The recorded operands' values at one moment (ms since the recording started)."""

    at_ms: float
    values: Mapping[str, int]


def slave_operands(slaves: Mapping[int, int]) -> tuple[list[str], list[str]]:
    """The input and output bits of slaves (address -> I/O code), as ``I a.b``/``Q a.b``:
    a bidirectional bit is both."""
    inputs, outputs = [], []
    for address in sorted(slaves):
        letters = IO_CODE_BITS[slaves[address] & 0xF]
        for bit, letter in enumerate(letters):
            if letter in "ib":
                inputs.append(f"I {address}.{bit}")
            if letter in "ob":
                outputs.append(f"Q {address}.{bit}")
    return inputs, outputs


def choose(inputs: list[str], outputs: list[str], patterns: Sequence[str] | None
           ) -> tuple[list[str], list[str]]:
    """The inputs to set and the operands to expect: all inputs and outputs without
    ``patterns``, else those the shell patterns match, and the flags (``F y.b``) they
    match, which are expected as outputs are."""
    if not patterns:
        return inputs, outputs
    flags = [f"F {y}.{b}" for y in range(FLAG_BYTES) for b in range(8)]

    def matched(names: Iterable[str]) -> list[str]:
        return [n for n in names
                if any(fnmatch.fnmatchcase(n.casefold(), p.strip().casefold()) for p in patterns)]

    return matched(inputs), matched(outputs) + matched(flags)


class Recording:
    """A recording as it goes, in bounded memory: each sample's changes (a step) are
    written to ``spool`` at once, and only the last value of each operand is kept, so an
    hour of 124 signals costs no more memory than a second (a sample of 31 slaves is
    some 20 kB as Python objects; a step on the spool is the few values that changed).
    ``write`` turns the spool into the scenario when the recording ends, however it
    ends: the tolerance window and the summary need its length."""

    def __init__(self, inputs: Sequence[str], expected: Sequence[str], spool: TextIO) -> None:
        self.inputs = list(inputs)
        self.expected = list(expected)
        self._spool = spool
        self._last: dict[str, int] = {}
        self._first_ms: float | None = None
        #: the samples taken, and the time of the last one since the first
        self.count = 0
        self.span_ms = 0.0

    def add(self, at_ms: float, values: Mapping[str, int]) -> None:
        """One sample, ``at_ms`` on any clock (times are written since the first)."""
        if self._first_ms is None:
            self._first_ms = at_ms
        first = self.count == 0
        sets = {n: values[n] for n in self.inputs
                if n in values and (first or self._last.get(n) != values[n])}
        expects = {n: values[n] for n in self.expected
                   if n in values and (first or self._last.get(n) != values[n])}
        self._last.update(values)
        self.count += 1
        self.span_ms = at_ms - self._first_ms
        if sets or expects or first:
            self._spool.write(json.dumps([round(self.span_ms), sets, expects]) + "\n")

    @property
    def every_ms(self) -> float:
        """The average sampling interval."""
        return self.span_ms / max(1, self.count - 1)

    def write(self, out: TextIO, tolerance_ms: float, *, program: str | None = None,
              comment: str = "") -> None:
        """The scenario (TOML text) to ``out``, step by step from the spool."""
        writer = ScenarioWriter()
        writer.comment(comment)
        if program is not None:
            writer.program(program)
        self._spool.flush()
        self._spool.seek(0)
        for line in self._spool:
            at_ms, sets, expects = json.loads(line)
            writer.step(at_ms, set=sets, expect=expects, within_ms=tolerance_ms)
            if len(writer.lines) >= STEP_LINES:
                out.write(writer.drain())
        out.write(writer.drain())


#: How many lines of steps ``Recording.write`` holds before it writes them out.
STEP_LINES = 4096


def to_scenario(
    samples: Sequence[Sample], inputs: Sequence[str], expected: Sequence[str],
    tolerance_ms: float, *, program: str | None = None, comment: str = "",
) -> str:
    """The scenario of a recording (TOML text) held in memory. Times are whole
    milliseconds since the first sample."""
    recording = Recording(inputs, expected, io.StringIO())
    for sample in samples:
        recording.add(sample.at_ms, sample.values)
    out = io.StringIO()
    recording.write(out, tolerance_ms, program=program, comment=comment)
    return out.getvalue()
