"""Trace writers: VCD read back by an independent reader (pyvcd), CSV, determinism."""

from __future__ import annotations

import csv
import io

from vcd.reader import TokenKind, tokenize

from asictl.sim.trace import Signal, Trace, to_csv, to_vcd


def sample() -> Trace:
    q = Signal("Q 31.0", 1)
    for t, v in [(0, 0), (250, 1), (500, 0), (1000, 1)]:
        q.record(t, v)
    fy = Signal("FY 3", 8)
    fy.record(0, 0)
    fy.record(120.5, 145)
    fy.record(120.5, 146)  # a second change at the same time replaces the first
    return Trace([q, fy], end_ms=1250)


def test_vcd_reads_back_with_pyvcd():
    text = to_vcd(sample())
    names, changes, time = {}, [], 0
    for token in tokenize(io.BytesIO(text.encode())):
        if token.kind is TokenKind.VAR:
            names[token.data.id_code] = (token.data.reference, token.data.size)
        elif token.kind is TokenKind.CHANGE_TIME:
            time = token.data
        elif token.kind in (TokenKind.CHANGE_SCALAR, TokenKind.CHANGE_VECTOR):
            changes.append((time, names[token.data.id_code][0], int(token.data.value)))
    assert sorted(names.values()) == [("FY_3", 8), ("Q_31_0", 1)]
    edges = [(t, v) for t, name, v in changes if name == "Q_31_0"]
    assert edges == [(0, 0), (250_000, 1), (500_000, 0), (1_000_000, 1)]
    assert (120_500, "FY_3", 146) in changes
    assert text.rstrip().endswith("#1250000")


def test_csv_has_one_row_per_change_time():
    rows = list(csv.reader(io.StringIO(to_csv(sample()))))
    assert rows[0] == ["time_ms", "Q 31.0", "FY 3"]
    assert rows[1:] == [["0", "0", "0"], ["120.5", "0", "146"], ["250", "1", "146"],
                        ["500", "0", "146"], ["1000", "1", "146"]]


def test_writers_are_deterministic():
    assert to_vcd(sample()) == to_vcd(sample())
    assert to_csv(sample()) == to_csv(sample())
