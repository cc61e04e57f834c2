"""A mixed load on a served board, sized for CI (benchmarks/bench_live.py runs 200
clients): live commands beyond --max-connections, Modbus polls and OPC UA reads at once
all get their answers. 200 such clients once had 8,089 live errors (the socket reset
connections beyond its limit) while Modbus and OPC UA answered every request."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))

from live_load import mixed_load, report, serve  # noqa: E402

#: More live clients than the live socket's 32 slots, within its waiting places.
LIVE, MODBUS, OPCUA = 48, 6, 6


def test_a_mixed_load_beyond_the_connection_limit_gets_every_answer(tmp_path):
    served = serve(tmp_path / "state")
    try:
        before = served.rss_kb()
        tallies = mixed_load(served, live=LIVE, modbus=MODBUS, opcua=OPCUA, seconds=6)
        grown = served.rss_kb() - before
    finally:
        served.stop()
    text = report(tallies)
    assert all(not tally.errors for tally in tallies.values()), text
    assert len(tallies["live"].times) >= LIVE, text  # every live client was answered
    assert tallies["modbus"].times and tallies["opcua"].times, text
    assert grown < 64 * 1024, f"the server grew by {grown} KB"
