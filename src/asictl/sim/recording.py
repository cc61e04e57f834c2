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
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

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


def to_scenario(
    samples: Sequence[Sample], inputs: Sequence[str], expected: Sequence[str],
    tolerance_ms: float, *, program: str | None = None, comment: str = "",
) -> str:
    """The scenario of a recording (TOML text). Times are whole milliseconds since the
    first sample."""
    out = ScenarioWriter()
    out.comment(comment)
    if program is not None:
        out.program(program)
    last: dict[str, int] = {}
    for index, sample in enumerate(samples):
        sets = {n: sample.values[n] for n in inputs if n in sample.values
                and (index == 0 or last.get(n) != sample.values[n])}
        expects = {n: sample.values[n] for n in expected if n in sample.values
                   and (index == 0 or last.get(n) != sample.values[n])}
        last.update(sample.values)
        if not sets and not expects and index:
            continue
        out.step(round(sample.at_ms), set=sets, expect=expects, within_ms=tolerance_ms)
    return out.text()
